"""The DSL where ROS 1 differs: one rospy node per process, params on the master, latching, one type per topic.

The DSL's behaviour on both ROS is in tests/both/test_dsl.py."""

from __future__ import annotations


import pytest
from helpers import one_call
from geometry_msgs.msg import Twist
from peer import Peer
from ros1_fixtures import master_state, wait_for
from std_msgs.msg import String, UInt32

from ipyros.core import errors


def test_two_nodes_share_the_process_node(make_node, ros_master):
    a = make_node("dsl_a").new.publish("/dsl_shared/a", msgType=String).create()
    b = make_node("dsl_b").new.publish("/dsl_shared/b", msgType=String).create()
    assert a.ros_name == b.ros_name == "/ipyros_test"
    pubs = master_state(ros_master)["pub"]
    assert pubs["/dsl_shared/a"] == ["/ipyros_test"] and pubs["/dsl_shared/b"] == ["/ipyros_test"]


def test_private_params_live_on_the_master(make_node, ros_master):
    nd = make_node("dsl_params")
    nd.params["gain"] = 1.5
    nd.create()
    master = one_call(ros_master)
    assert master.getParam("/pytest", "/dsl_params/gain") == [1, "Parameter [/dsl_params/gain]", 1.5]
    nd.params["mode"] = "fast"
    assert master.getParam("/pytest", "/dsl_params/mode")[2] == "fast"
    master.setParam("/pytest", "/dsl_params/gain", 2.5)  # someone else changes it: we read it live
    assert nd.params["gain"] == 2.5
    del nd.params["mode"]
    assert master.hasParam("/pytest", "/dsl_params/mode")[2] is False
    with pytest.raises(errors.DeclarationError, match="without ~ or /"):
        nd.params["~gain"] = 1


def test_shutdown_unregisters_everything_from_the_master(make_node, ros_master):
    nd = make_node("dsl_down")
    nd.new.publish("/dsl_down/out", msgType=String).subscribe("/dsl_down/in", handler=print, msgType=String)
    nd.timer(0.05, lambda: None, name="t")
    nd.create()
    nd.shutdown()
    state = master_state(ros_master)
    assert "/dsl_down/out" not in state["pub"] and "/dsl_down/in" not in state["sub"]
    with pytest.raises(errors.NodeStateError, match="call dsl_down.create"):
        nd.write("/dsl_down/out", String())


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


def test_a_declaration_of_another_type_than_the_live_topic_is_refused(make_node):
    with Peer("publish_type.py", "/err_live", "std_msgs/String") as peer:
        peer.wait_line("ready")
        nd = make_node("err_live").create()
        with pytest.raises(errors.TopicTypeConflict, match="/err_live already carries std_msgs/String, not "
                                                           "geometry_msgs/Twist; declare msgType='std_msgs/String'"):
            nd.new.subscribe("/err_live", handler=print, msgType=Twist)
        assert nd.model().topics == []
        nd.new.subscribe("/err_live", handler=print, msgType=String)  # the right type is fine
