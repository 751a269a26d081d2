"""The paper's DSL on ROS 2: the same declarations, live reshaping and one-line errors as on ROS 1."""

from __future__ import annotations

import threading

import pytest
from ros2_fixtures import Peer, wait_for
from std_msgs.msg import String, UInt32
from std_srvs.srv import SetBool

from ipyros.core import errors
from ipyros.dsl import engine_of


def test_each_dsl_node_is_a_ros2_node_and_talks_to_other_processes(make_node):
    heard = []
    with Peer("echo.py", "/r2/chatter") as peer:
        peer.wait_line("ready")
        talker = make_node("talker", namespace="/r2").new.publish("chatter", msgType=String).create()
        make_node("listener").new.subscribe("/r2/back", handler=lambda m: heard.append(m.data),
                                            msgType="std_msgs/msg/String").create()
        wait_for(lambda: talker.write("chatter", String(data="hi")) or any("heard: hi" in x for x in peer.lines),
                 timeout=20, interval=0.1, what="the peer to hear the DSL node")

        def peer_lists_both() -> bool:  # node names travel apart from endpoints: the peer may learn them later
            asked = len(peer.lines)
            peer.proc.stdin.write("nodes\n")
            peer.proc.stdin.flush()
            listing = wait_for(lambda: next((x for x in peer.lines[asked:] if x.startswith("nodes: ")), None),
                               timeout=10, what="the peer's node list")
            return {"/r2/talker", "/listener"} <= set(listing.split())

        wait_for(peer_lists_both, timeout=20, interval=0.2, what="the peer to list both DSL nodes")
        assert talker.ros_name == "/r2/talker"  # a ROS 2 node of its own
        with pytest.raises(errors.MessageTypeError, match="chatter carries std_msgs/String, not std_msgs/UInt32"):
            talker.write("chatter", UInt32(data=1))
        # The peer's name is taken: a DSL node of that name is refused, and nothing of it runs (once the
        # graph knows the name: discovery may tell of it a moment after the peer's topics).
        backend = engine_of(talker).session.backend
        wait_for(lambda: "/echo_peer" in backend.graph_snapshot().nodes, timeout=20, what="the peer's name")
        taker = make_node("echo_peer")
        taker.new.publish("/r2/taken", msgType=String)
        with pytest.raises(errors.NodeStateError, match="a node named /echo_peer is already running in the ROS 2 graph"):
            taker.create()
        assert not taker.created and "/echo_peer" not in engine_of(talker).session.process.hosts()


def test_timers_params_and_services(make_node, failures):
    ticks = []
    nd = make_node("worker", namespace="/r2")
    nd.timer(0.02, lambda: ticks.append(1), name="tick")
    nd.params["gain"] = 1.5
    answers = {"value": None}

    def set_bool(request):
        return answers["value"] or SetBool.Response(success=request.data, message="done")

    nd.new.service("~set", SetBool, handler=set_bool).create()
    wait_for(lambda: len(ticks) >= 5, what="the timer")
    assert nd.params["gain"] == 1.5
    nd.params["gain"] = 3  # another type: parameters of a DSL node are dynamically typed
    assert nd.params["gain"] == 3
    with pytest.raises(errors.DeclarationError, match="a ROS 2 parameter holds bool, int, float, str"):
        nd.params["gain"] = {"a": 1}
    assert nd.params["gain"] == 3
    nd.remove(timer="tick")
    stopped = len(ticks)
    threading.Event().wait(0.2)
    assert len(ticks) <= stopped + 1

    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    context = rclpy.Context()  # a caller of its own, as another process would be
    rclpy.init(context=context)
    try:
        client_node = rclpy.create_node("r2_caller", context=context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(client_node)
        client = client_node.create_client(SetBool, "/r2/worker/set")
        assert client.wait_for_service(timeout_sec=10)

        def call(data: bool):
            # Right after discovery a reply can go out before the client's reply reader is
            # matched, and DDS drops it ("failed to send response"): ask again, as ROS 2 clients do.
            for _ in range(5):
                future = client.call_async(SetBool.Request(data=data))
                executor.spin_until_future_complete(future, timeout_sec=2)
                if future.done():
                    return future.result()
                client.remove_pending_request(future)
            raise AssertionError("no answer from /r2/worker/set in 5 tries")

        assert call(True).message == "done"
        answers["value"] = "yes"  # the wrong type: the caller gets the default, the session is told
        assert call(True).message == ""
        assert "returned 'yes', which is not a SetBool.Response" in str(failures[-1].error)
        assert nd.status().row("/r2/worker/set").errors >= 1
        # A change made from outside, through the node's parameter services, is what nd.params reads.
        from rclpy.parameter import Parameter
        from rclpy.parameter_client import AsyncParameterClient

        params = AsyncParameterClient(client_node, "/r2/worker")
        assert params.wait_for_services(timeout_sec=10)
        wait_for(lambda: executor.spin_until_future_complete(
            params.set_parameters([Parameter("gain", value=7)]), timeout_sec=1) or nd.params["gain"] == 7,
            timeout=15, what="the outside change in nd.params")
        executor.shutdown()
        client_node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)
        context.destroy()  # its participant deleted now: else its Fast DDS ports outlive the process


def test_bad_input_is_the_same_line_as_on_ros1(make_node):
    nd = make_node("bad", namespace="/r2").create()

    async def on_msg(msg):
        pass

    with pytest.raises(errors.HandlerError, match="is an async def: ROS calls it on its own thread"):
        nd.new.subscribe("/r2/x", handler=on_msg, msgType=String)
    with pytest.raises(errors.DeclarationError, match="timer period must be a number of seconds from 0.0001"):
        nd.timer(1e-12, print)
    with pytest.raises(errors.MessageTypeError, match="'std_srvs/SetBool' is a service type, not a message type"):
        nd.new.publish("/r2/x", msgType="std_srvs/SetBool")
    with pytest.raises(errors.DeclarationError, match="but has no basenode"):
        nd.reuse.publish("/r2/y", msgType=String)
    with pytest.raises(errors.BaseNodeError, match=r"launch file 'robot.launch' not found \(relative to "):
        make_node("bad_launch").baseLaunch("robot.launch", "planner")
    assert nd.model().topics == [] and nd.model().timers == []
