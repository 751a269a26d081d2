"""The paper's DSL on each ROS, from one source: create, reshape live, timers, params, handlers that fail.

Run in the ROS 1 venv against a rosmaster of the run's own and in the ROS 2 venv in a DDS
domain of the run's own; peers are plain nodes of whichever ROS runs (``both/peers/``).
"""

from __future__ import annotations

import threading

import pytest
from geometry_msgs.msg import Pose, Twist
from std_msgs.msg import String, UInt32
from support import graph_forgets, graph_knows, wait_for

from ipyros.core import errors
from ipyros.core.model import NodeModel
from ipyros.dsl import engine_of
from ipyros.ipython.display import render_text, renderable


def connected(node, topic: str) -> bool:
    """Whether ``node``'s publication of ``topic`` has a subscriber connected (the first message would arrive)."""
    return any(f.topic == node.resolve(topic) and f.connections for f in engine_of(node).sent())


def test_messages_flow_between_two_nodes_of_the_session(make_node):
    seen = []
    make_node("dsl_listener").new.subscribe(topic="/dsl_flow", handler=seen.append, msgType=String).create()
    talker = make_node("dsl_talker")
    talker.new.publish(topic="/dsl_flow", msgType="std_msgs/String")
    talker.create()
    wait_for(lambda: connected(talker, "/dsl_flow"), timeout=20, what="the connection")
    talker.write("/dsl_flow", String(data="hello"))
    wait_for(lambda: seen, timeout=20, what="the message")
    assert seen[0].data == "hello"


def test_a_node_hears_a_peer_and_a_peer_hears_a_node(make_node, peer):
    heard = []
    make_node("dsl_ear").new.subscribe("/dsl_peer/out", handler=lambda m: heard.append(m.data), msgType=String).create()
    talker = peer("talk.py", "/dsl_peer/out", "std_msgs/String", 20, "data='from the peer'")
    talker.wait_line("ready")
    wait_for(lambda: heard, timeout=20, what="the peer's message")
    assert heard[0] == "from the peer"
    listener = peer("listen.py", "/dsl_peer/in", "std_msgs/String", "data")
    listener.wait_line("ready")
    mouth = make_node("dsl_mouth").new.publish("/dsl_peer/in", msgType=String).create()
    wait_for(lambda: connected(mouth, "/dsl_peer/in"), timeout=20, what="the peer to connect")
    mouth.write("/dsl_peer/in", String(data="from the node"))
    assert listener.wait_line("heard") == "heard 'from the node'"


def test_nodes_of_one_session_on_one_topic_each_get_their_own_message(make_node):
    """As nodes in separate processes would: a handler that edits its message in place (the paper's
    controlVelocity) must not change what another node of the session sees."""
    edited, watched = [], []

    def edit(msg):
        msg.data = "edited"
        edited.append(msg.data)

    make_node("dsl_editor").new.subscribe("/dsl_shared_msg", handler=edit, msgType=String).create()
    make_node("dsl_watcher").new.subscribe("/dsl_shared_msg", handler=lambda m: watched.append(m.data),
                                          msgType=String).create()
    talker = make_node("dsl_shared_talker").new.publish("/dsl_shared_msg", msgType=String).create()
    wait_for(lambda: talker.write("/dsl_shared_msg", String(data="original")) or (edited and watched),
             timeout=20, interval=0.1, what="both handlers called")
    assert set(watched) == {"original"}


def test_a_second_running_node_with_the_same_name_is_refused(make_node):
    make_node("dsl_twin").create()
    with pytest.raises(errors.NodeStateError, match="already running in this session"):
        make_node("dsl_twin").create()


def test_a_handler_swapped_under_a_200_hz_stream_loses_none_and_doubles_none(make_node, peer):
    seen: list[tuple[str, int]] = []
    lock = threading.Lock()

    def version(tag):
        def handler(msg):
            with lock:
                seen.append((tag, msg.data))
        handler.__name__ = f"handler_{tag}"
        return handler

    nd = make_node("dsl_swap").new.subscribe("/dsl_swap/seq", handler=version("v0"), msgType=UInt32).create()
    count = 600  # 3 s at 200 Hz
    stream = peer("seq.py", "/dsl_swap/seq", count, 200)
    stream.wait_line("started", timeout=30)
    swaps = 0
    while not any("done" in line for line in stream.lines):
        swaps += 1
        nd.new.subscribe("/dsl_swap/seq", handler=version(f"v{swaps}"), msgType=UInt32)  # the paper's swap
        threading.Event().wait(0.01)  # a swap every 10 ms: the stream is cut many times
    wait_for(lambda: len(seen) >= count, timeout=20, what="every message")
    numbers = [n for _, n in seen]
    assert sorted(numbers) == list(range(count)), "a message was lost or handled twice"
    tags = [int(tag[1:]) for tag, _ in seen]
    assert tags == sorted(tags), "each swap is a clean cut in the stream"
    assert len(set(tags)) > 5 and swaps >= 10, "the stream was served by many versions in turn"
    assert nd.handler("/dsl_swap/seq").__name__ == f"handler_v{swaps}"
    assert len(nd.versions("/dsl_swap/seq")) == swaps + 1


speed = 1.0


def test_handlers_read_globals_at_call_time(make_node):
    global speed
    seen = []

    def scaled(msg):
        seen.append(msg.data * speed)

    nd = make_node("dsl_globals")
    nd.new.subscribe(topic="/dsl_globals", handler=scaled, msgType=UInt32)
    nd.new.publish(topic="/dsl_globals", msgType=UInt32)
    nd.create()
    wait_for(lambda: connected(nd, "/dsl_globals"), timeout=20, what="the node to hear itself")
    nd.write("/dsl_globals", UInt32(data=2))
    wait_for(lambda: seen == [2.0], what="the first message")
    speed = 6.0
    try:
        nd.write("/dsl_globals", UInt32(data=2))
        wait_for(lambda: seen == [2.0, 12.0], what="the second message, with the new speed")
    finally:
        speed = 1.0


def test_topics_are_added_and_removed_while_running(make_node):
    nd = make_node("dsl_reshape").create()
    nd.new.publish(topic="/dsl_reshape/out", msgType=Twist)
    nd.new.subscribe(topic="/dsl_reshape/in", handler=lambda m: None, msgType=Twist)
    assert nd.ros_name in graph_knows("/dsl_reshape/out", "publishers")
    assert nd.ros_name in graph_knows("/dsl_reshape/in", "subscribers")
    nd.new.unpublish("/dsl_reshape/out")
    nd.remove("/dsl_reshape/in")
    graph_forgets("/dsl_reshape/out", "publishers")
    graph_forgets("/dsl_reshape/in", "subscribers")
    assert nd.model().topics == []


def test_changing_a_topic_type_while_running(make_node):
    nd = make_node("dsl_retype").new.publish("/dsl_retype", msgType=String).create()
    nd.remove("/dsl_retype")
    nd.new.publish("/dsl_retype", msgType=Twist)
    nd.write("/dsl_retype", Twist())
    with pytest.raises(errors.MessageTypeError, match="carries geometry_msgs/Twist, not std_msgs/String"):
        nd.write("/dsl_retype", String(data="x"))


def test_timer_declare_replace_remove(make_node):
    ticks = {"a": 0, "b": 0}

    def tick_a(event):
        ticks["a"] += 1

    def tick_b():  # a timer handler may ignore the event
        ticks["b"] += 1

    nd = make_node("dsl_timer").create()
    nd.timer(0.02, tick_a, name="beat")
    wait_for(lambda: ticks["a"] >= 5, what="the timer's ticks")
    nd.timer(0.02, tick_b, name="beat")  # replaces it
    wait_for(lambda: ticks["b"] >= 5, what="the replacing timer's ticks")
    a_after = ticks["a"]
    wait_for(lambda: ticks["b"] >= 10, what="more ticks")
    assert ticks["a"] <= a_after + 1
    assert [t.handler for t in nd.model().timers] == ["tick_b"]
    nd.remove(timer="beat")
    b_after = ticks["b"]
    threading.Event().wait(0.2)  # a removed timer must stay silent: a window to observe it in
    assert ticks["b"] <= b_after + 1
    with pytest.raises(errors.NotDeclaredError, match="has no timer 'beat'"):
        nd.remove(timer="beat")


def test_timer_errors(make_node):
    nd = make_node("dsl_timer_bad")
    with pytest.raises(errors.DeclarationError, match="a number of seconds from 0.0001"):
        nd.timer(0, lambda: None)
    with pytest.raises(errors.HandlerError, match="must take one argument, the timer event"):
        nd.timer(1.0, lambda a, b: None)


def test_private_params_before_and_after_create(make_node):
    nd = make_node("dsl_params")
    nd.params["gain"] = 1.5
    nd.create()
    assert nd.params["gain"] == 1.5
    nd.params["mode"] = "fast"
    assert dict(nd.params) == {"gain": 1.5, "mode": "fast"}
    del nd.params["mode"]
    assert "mode" not in nd.params
    with pytest.raises(KeyError, match="has no parameter 'mode'"):
        nd.params["mode"]
    with pytest.raises(errors.DeclarationError, match="without ~ or /"):
        nd.params["~gain"] = 1


def test_shutdown_takes_everything_off_the_graph(make_node):
    nd = make_node("dsl_down")
    nd.new.publish("/dsl_down/out", msgType=String).subscribe("/dsl_down/in", handler=print, msgType=String)
    nd.timer(0.05, lambda: None, name="t")
    nd.create()
    graph_knows("/dsl_down/out", "publishers")
    nd.shutdown()
    graph_forgets("/dsl_down/out", "publishers")
    graph_forgets("/dsl_down/in", "subscribers")
    with pytest.raises(errors.NodeStateError, match="call dsl_down.create"):
        nd.write("/dsl_down/out", String())


def test_a_raising_handler_is_reported_counted_and_the_node_keeps_serving(make_node, failures):
    good = []

    def broken(msg):
        return 1 / 0

    nd = make_node("dsl_crash")
    nd.new.subscribe("/dsl_crash/bad", handler=broken, msgType=UInt32)
    nd.new.subscribe("/dsl_crash/good", handler=good.append, msgType=UInt32)
    nd.new.publish("/dsl_crash/bad", msgType=UInt32).publish("/dsl_crash/good", msgType=UInt32)
    nd.create()
    wait_for(lambda: connected(nd, "/dsl_crash/bad") and connected(nd, "/dsl_crash/good"), timeout=20,
             what="the node to hear itself")
    for i in range(20):
        nd.write("/dsl_crash/bad", UInt32(data=i))
        nd.write("/dsl_crash/good", UInt32(data=i))
    wait_for(lambda: len(good) == 20, what="the other topic to keep flowing")
    wait_for(lambda: nd.status().row("/dsl_crash/bad").errors == 20, what="the errors counted")
    assert len(failures) == 1, "reports are rate-limited"
    report = failures[0]
    assert report.handler == "broken" and isinstance(report.error, ZeroDivisionError)
    assert "in broken" in report.traceback and "return 1 / 0" in report.traceback
    assert "rospy" not in report.traceback and "rclpy" not in report.traceback and "slots.py" not in report.traceback


def test_the_model_is_plain_data_and_round_trips(make_node):
    nd = make_node("dsl_model")
    (nd.new.subscribe(topic="/turtle1/pose", handler=print, msgType=Pose)
           .publish(topic="cmd_vel", msgType=Twist, latch=True))
    nd.timer(1.0, print, name="tick")
    nd.params["gain"] = 2
    data = nd.model().to_dict()
    assert data["topics"][1] == {"name": "cmd_vel", "resolved": "/cmd_vel", "direction": "publish",
                                 "type": "geometry_msgs/Twist", "role": "new", "handler": None, "latch": True,
                                 "qos": None}
    assert NodeModel.from_dict(data) == nd.model()


def test_names_resolve_in_the_node_namespace(make_node):
    nd = make_node("dsl_ns", namespace="/robot1")
    nd.new.publish("cmd_vel", msgType=Twist).publish("~status", msgType=String).publish("/abs", msgType=String)
    assert [t.resolved for t in nd.model().topics] == ["/robot1/cmd_vel", "/robot1/dsl_ns/status", "/abs"]


def test_the_node_displays_as_a_table(make_node):
    nd = make_node("dsl_show")
    nd.new.publish("/dsl_show", msgType=Twist)
    text = render_text(renderable(nd))
    assert "rosNode /dsl_show (declared)" in text and "geometry_msgs/Twist" in text and "publish" in text


def test_every_change_is_in_the_history(make_node):
    nd = make_node("dsl_history")
    nd.new.publish("/dsl_history/out", msgType=Twist)
    nd.create()
    nd.new.subscribe("/dsl_history/in", handler=print, msgType="std_msgs/String")
    nd.timer(0.5, print, name="tick")
    nd.params["gain"] = 2
    nd.remove("/dsl_history/in")
    assert [c.change for c in nd.history()] == [
        "new.publish /dsl_history/out [geometry_msgs/Twist]", "create()",
        "new.subscribe /dsl_history/in [std_msgs/String] -> print", "timer tick every 0.5 s -> print",
        "params['gain'] = 2", "remove /dsl_history/in"]
    assert "history of /dsl_history" in render_text(renderable(nd.history()))


def test_the_dsl_is_all_a_node_shows(make_node):
    """``nd.<TAB>`` offers the paper's DSL and keeping the work; ipyros's own machinery is on the engine."""
    public = {name for name in dir(make_node("dsl_tab")) if not name.startswith("_")}
    assert public == {
        "name", "fullname", "created", "ros_name", "base", "basenode_name", "model", "handler", "resolve",
        "new", "reuse", "params", "baseNode", "basePackage", "baseLaunch", "baseBag", "discover", "create",
        "shutdown", "timer", "remove", "write", "send_goal", "save", "load", "export", "status", "history",
        "versions", "revert", "restore_versions", "running", "on_param", "guard", "estop", "release", "now", "machine"}


def test_declaring_a_subscription_again_reads_as_a_handler_swap(make_node):
    """Redeclared, a subscription is not a second one: the chain and the history say "handler a → b" (issue 25)."""
    nd = make_node("dsl_swap_said")

    def append(msg):
        pass

    def keep(msg):
        pass

    nd.new.subscribe("/dsl_swap_said/pose", append, msgType="std_msgs/String")
    shown = repr(nd.new.subscribe("/dsl_swap_said/pose", keep, msgType="std_msgs/String"))
    assert "subscribe /dsl_swap_said/pose: handler append → keep" in shown, shown
    assert nd.history()[-1].change == "new.subscribe /dsl_swap_said/pose: handler append → keep"
