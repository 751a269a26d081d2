"""The paper's DSL against a real master: create, reshape live, timers, params, errors."""

from __future__ import annotations

import threading
import xmlrpc.client

import pytest
from geometry_msgs.msg import Pose, Twist
from std_msgs.msg import String, UInt32

from ros1_fixtures import master_state, wait_for
from peer import Peer

from ipyros.core import errors
from ipyros.node.dsl import engine_of


def test_two_nodes_share_the_process_node(make_node, ros_master):
    a = make_node("dsl_a").new.publish("/dsl_shared/a", msgType=String).create()
    b = make_node("dsl_b").new.publish("/dsl_shared/b", msgType=String).create()
    assert a.ros_name == b.ros_name == "/ipyros_test"
    pubs = master_state(ros_master)["pub"]
    assert pubs["/dsl_shared/a"] == ["/ipyros_test"] and pubs["/dsl_shared/b"] == ["/ipyros_test"]


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
    wait_for(lambda: talker.write("/dsl_shared_msg", String("original")) or (edited and watched),
             interval=0.1, what="both handlers called")
    assert set(watched) == {"original"}


def test_a_second_running_node_with_the_same_name_is_refused(make_node):
    make_node("dsl_twin").create()
    with pytest.raises(errors.NodeStateError, match="already running in this session"):
        make_node("dsl_twin").create()


def test_messages_flow_between_two_nodes_through_the_master(make_node):
    seen = []
    listener = make_node("dsl_listener").new.subscribe(topic="/dsl_flow", handler=seen.append, msgType=String)
    listener.create()
    talker = make_node("dsl_talker")
    talker.new.publish(topic="/dsl_flow", msgType="std_msgs/String")
    talker.create()
    wait_for(lambda: engine_of(talker).writer("/dsl_flow")[0].connections(), what="connection")
    talker.write("/dsl_flow", String("hello"))
    wait_for(lambda: seen, what="message")
    assert seen[0].data == "hello"


def test_handler_swap_under_200hz_loses_nothing_and_doubles_nothing(make_node):
    old, new = [], []

    def old_handler(msg):
        old.append(msg.data)

    def new_handler(msg):
        new.append(msg.data)

    nd = make_node("dsl_swap")
    nd.new.subscribe(topic="/dsl_swap/stream", handler=old_handler, msgType=UInt32)
    nd.create()
    count = 800  # 4 s at 200 Hz
    with Peer("publish_seq.py", "/dsl_swap/stream", count, 200) as peer:
        peer.wait_line("started")
        wait_for(lambda: len(old) >= 300, what="300 messages to the old handler")
        nd.new.subscribe(topic="/dsl_swap/stream", handler=new_handler, msgType=UInt32)  # the paper's swap
        peer.wait_line("done", timeout=30)
    wait_for(lambda: len(old) + len(new) >= count, timeout=10, what="every message")
    assert not set(old) & set(new), "a message was handled by both handlers"
    assert sorted(old + new) == list(range(count)), "a message was lost or duplicated"
    assert new and max(old) < min(new), "the swap must be a clean cut in the stream"
    assert nd.handler("/dsl_swap/stream") is new_handler
    assert nd.model().topic("/dsl_swap/stream", "subscribe").handler == "new_handler"


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
    wait_for(lambda: engine_of(nd).writer("/dsl_globals")[0].connections(), what="self connection")
    nd.write("/dsl_globals", UInt32(2))
    wait_for(lambda: seen == [2.0], what="first message")
    speed = 6.0
    nd.write("/dsl_globals", UInt32(2))
    wait_for(lambda: seen == [2.0, 12.0], what="second message with the new speed")
    speed = 1.0


def test_topics_are_added_and_removed_while_running(make_node, ros_master):
    nd = make_node("dsl_reshape").create()
    nd.new.publish(topic="/dsl_reshape/out", msgType=Twist)
    nd.new.subscribe(topic="/dsl_reshape/in", handler=lambda m: None, msgType=Twist)
    wait_for(lambda: "/ipyros_test" in master_state(ros_master)["pub"].get("/dsl_reshape/out", []), what="pub")
    assert "/ipyros_test" in master_state(ros_master)["sub"]["/dsl_reshape/in"]
    nd.new.unpublish("/dsl_reshape/out")
    nd.remove("/dsl_reshape/in")
    state = master_state(ros_master)
    assert "/dsl_reshape/out" not in state["pub"] and "/dsl_reshape/in" not in state["sub"]
    assert nd.model().topics == []


def test_changing_a_topic_type_while_running(make_node, ros_master):
    nd = make_node("dsl_retype").new.publish("/dsl_retype", msgType=String).create()
    nd.remove("/dsl_retype")
    nd.new.publish("/dsl_retype", msgType=Twist)
    nd.write("/dsl_retype", Twist())
    with pytest.raises(errors.MessageTypeError, match="carries geometry_msgs/Twist, not std_msgs/String"):
        nd.write("/dsl_retype", String("x"))


def test_timer_declare_replace_remove(make_node):
    ticks = {"a": 0, "b": 0}

    def tick_a(event):
        ticks["a"] += 1

    def tick_b():  # a timer handler may ignore the event
        ticks["b"] += 1

    nd = make_node("dsl_timer").create()
    nd.timer(0.02, tick_a, name="beat")
    wait_for(lambda: ticks["a"] >= 5, what="timer ticks")
    nd.timer(0.02, tick_b, name="beat")  # replaces
    wait_for(lambda: ticks["b"] >= 5, what="replaced timer ticks")
    a_after = ticks["a"]
    wait_for(lambda: ticks["b"] >= 10, what="more ticks")
    assert ticks["a"] <= a_after + 1
    assert [t.handler for t in nd.model().timers] == ["tick_b"]
    nd.remove(timer="beat")
    b_after = ticks["b"]
    threading.Event().wait(0.2)  # a removed timer must stay silent: observe a window
    assert ticks["b"] <= b_after + 1
    with pytest.raises(errors.NotDeclaredError, match="has no timer 'beat'"):
        nd.remove(timer="beat")


def test_timer_errors(make_node):
    nd = make_node("dsl_timer_bad")
    with pytest.raises(errors.DeclarationError, match="a number of seconds from 0.0001"):
        nd.timer(0, lambda: None)
    with pytest.raises(errors.HandlerError, match="must take one argument, the timer event"):
        nd.timer(1.0, lambda a, b: None)


def test_private_params_before_and_after_create(make_node, ros_master):
    nd = make_node("dsl_params")
    nd.params["gain"] = 1.5
    nd.create()
    master = xmlrpc.client.ServerProxy(ros_master)
    assert master.getParam("/pytest", "/dsl_params/gain") == [1, "Parameter [/dsl_params/gain]", 1.5]
    nd.params["mode"] = "fast"
    assert master.getParam("/pytest", "/dsl_params/mode")[2] == "fast"
    master.setParam("/pytest", "/dsl_params/gain", 2.5)  # someone else changes it: we read it live
    assert nd.params["gain"] == 2.5
    del nd.params["mode"]
    assert master.hasParam("/pytest", "/dsl_params/mode")[2] is False
    with pytest.raises(errors.DeclarationError, match="without ~ or /"):
        nd.params["~gain"] = 1


def test_shutdown_unregisters_everything(make_node, ros_master):
    nd = make_node("dsl_down")
    nd.new.publish("/dsl_down/out", msgType=String).subscribe("/dsl_down/in", handler=print, msgType=String)
    nd.timer(0.05, lambda: None, name="t")
    nd.create()
    nd.shutdown()
    state = master_state(ros_master)
    assert "/dsl_down/out" not in state["pub"] and "/dsl_down/in" not in state["sub"]
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
    wait_for(lambda: engine_of(nd).writer("/dsl_crash/bad")[0].connections()
             and engine_of(nd).writer("/dsl_crash/good")[0].connections(), what="connections")
    for i in range(20):
        nd.write("/dsl_crash/bad", UInt32(i))
        nd.write("/dsl_crash/good", UInt32(i))
    wait_for(lambda: len(good) == 20, what="the other topic to keep flowing")
    wait_for(lambda: nd.status().row("/dsl_crash/bad").errors == 20, what="errors counted")
    assert len(failures) == 1, "reports are rate-limited"
    report = failures[0]
    assert report.handler == "broken" and isinstance(report.error, ZeroDivisionError)
    assert "in broken" in report.traceback and "return 1 / 0" in report.traceback
    assert "rospy" not in report.traceback and "slots.py" not in report.traceback


def test_model_is_plain_data_and_round_trips(make_node):
    from ipyros.core.model import NodeModel

    nd = make_node("dsl_model")
    (nd.new.subscribe(topic="/turtle1/pose", handler=print, msgType=Pose)
           .publish(topic="cmd_vel", msgType=Twist, latch=True))
    nd.timer(1.0, print, name="tick")
    nd.params["gain"] = 2
    data = nd.model().to_dict()
    assert data["topics"][1] == {"name": "cmd_vel", "resolved": "/cmd_vel", "direction": "publish",
                                 "type": "geometry_msgs/Twist", "role": "new", "handler": None, "latch": True, "qos": None}
    assert NodeModel.from_dict(data) == nd.model()


def test_names_resolve_in_the_node_namespace(make_node):
    nd = make_node("dsl_ns", namespace="/robot1")
    nd.new.publish("cmd_vel", msgType=Twist).publish("~status", msgType=String).publish("/abs", msgType=String)
    assert [t.resolved for t in nd.model().topics] == ["/robot1/cmd_vel", "/robot1/dsl_ns/status", "/abs"]


def test_the_node_displays_as_a_table(make_node):
    from ipyros.ipython.display import render_text, renderable

    nd = make_node("dsl_show")
    nd.new.publish("/dsl_show", msgType=Twist)
    text = render_text(renderable(nd))
    assert "rosNode /dsl_show (declared)" in text and "geometry_msgs/Twist" in text and "publish" in text


def test_every_change_is_in_the_history(make_node):
    from ipyros.ipython.display import render_text

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
    assert "history of /dsl_history" in render_text(nd.history())


def test_qos_on_ros1_latches_when_transient_local_and_is_kept_for_ros2(make_node):
    """TCPROS is reliable: of a QoS only durability means something on ROS 1 (a latched topic); the rest is
    kept in the model, so that the node loads on ROS 2 as declared."""
    talker = make_node("dsl_qos_talker").new.publish("/dsl_qos", msgType=String, qos="latched").create()
    talker.new.subscribe("/dsl_qos_scan", print, msgType=String, qos="sensor_data")
    talker.write("/dsl_qos", String("kept"))
    late = []
    make_node("dsl_qos_late").new.subscribe("/dsl_qos", handler=lambda m: late.append(m.data), msgType=String).create()
    wait_for(lambda: late == ["kept"], what="the latched message for a subscriber that came later")
    assert talker.model().topic("/dsl_qos_scan", "subscribe").qos == {"depth": 5, "reliability": "best_effort",
                                                                      "durability": "volatile"}
    with pytest.raises(errors.DeclarationError, match="qos='fast' is not a profile"):
        talker.new.subscribe("/dsl_qos_scan", print, msgType=String, qos="fast")


def test_a_topic_read_as_two_types_in_one_session_is_refused(make_node):
    """rospy reads a topic once per process: a second reader of another type is told, in one line."""
    make_node("dsl_two_types_a").new.subscribe("/dsl_two_types", handler=print, msgType=String).create()
    b = make_node("dsl_two_types_b")
    b.new.subscribe("/dsl_two_types", handler=print, msgType=UInt32)
    with pytest.raises(errors.DeclarationError, match="^/dsl_two_types already carries std_msgs/String, "
                                                      "not std_msgs/UInt32; declare msgType='std_msgs/String'"):
        b.create()
    assert not b.created
