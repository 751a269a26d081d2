"""Bad input gets one clear line, and nothing already running is disturbed (on each ROS)."""

from __future__ import annotations

import pytest
from geometry_msgs.msg import Twist
from std_msgs.msg import String, UInt32
from support import wait_for

from ipyros.core import errors
from ipyros.dsl import engine_of


@pytest.mark.parametrize("spec, message", [
    ("geometry_msgs/Twst", "unknown message type 'geometry_msgs/Twst': package 'geometry_msgs' has no 'Twst'; "
                           "did you mean geometry_msgs/Twist"),
    ("geometry_msg/Twist", "unknown message package 'geometry_msg' in 'geometry_msg/Twist'; it is not installed here "
                            "({install} install {package}), or did you mean geometry_msgs"),
    ("Twist", "malformed message type 'Twist': write 'package/Type'; did you mean geometry_msgs/Twist"),
    ("a/b/c", "malformed message type 'a/b/c'"),
    (42, "message type must be a class or a 'pkg/Type' string, not int"),
    (dict, "dict is not a ROS message class"),
])
def test_unknown_or_malformed_message_type(make_node, session, spec, message):
    # What to install is said as this machine installs it: Debian's package (ROS 1), a wheel (ROS 2 from PyPI).
    ros1 = session.backend.name == "ROS 1"
    message = message.format(install="apt" if ros1 else "pip", package="python3-geometry-msg" if ros1 else
                             "ros-geometry-msg")
    with pytest.raises(errors.MessageTypeError) as caught:
        make_node("err_type").new.publish("/err", msgType=spec)
    assert message in str(caught.value)
    assert "\n" not in str(caught.value)


def test_missing_and_disagreeing_types(make_node):
    nd = make_node("err_type2")
    with pytest.raises(errors.MessageTypeError, match="no message type given; add msgType="):
        nd.new.publish("/err")
    with pytest.raises(errors.MessageTypeError, match="disagree; give just one"):
        nd.new.publish("/err", msgType=Twist, type=String)
    nd.new.publish("/err", type="geometry_msgs/Twist")  # the paper's other spelling
    assert nd.model().topics[0].type == "geometry_msgs/Twist"


@pytest.mark.parametrize("name", ["bad name", "1abc", "/a//b", "a/", "", "/a-b"])
def test_invalid_topic_names(make_node, name):
    with pytest.raises(errors.TopicNameError, match="topic name"):
        make_node("err_names").new.publish(name, msgType=Twist)


def test_invalid_node_names(make_node):
    with pytest.raises(errors.TopicNameError, match="invalid node name 'a/b'"):
        make_node("a/b")


def test_handler_not_callable_or_wrong_arity(make_node):
    nd = make_node("err_handler")
    with pytest.raises(errors.HandlerError, match=r"handler for err_handler /x is str 'showPose', not a function"):
        nd.new.subscribe("/x", handler="showPose", msgType=Twist)
    with pytest.raises(errors.HandlerError, match=r"handler two\(a, b\) for err_handler /x must take one argument, "
                                                 "the message"):
        def two(a, b):
            pass
        nd.new.subscribe("/x", handler=two, msgType=Twist)
    with pytest.raises(errors.HandlerError, match="needs handler="):
        nd.new.subscribe("/x", msgType=Twist)
    with pytest.raises(errors.HandlerError, match="relays messages unchanged and takes no handler"):
        nd.reuse.subscribe("/x", handler=print, msgType=Twist)
    assert nd.model().topics == []


def test_write_errors(make_node):
    nd = make_node("err_write")
    nd.new.publish("/err_write/out", msgType=Twist)
    with pytest.raises(errors.NodeStateError, match=r"err_write is not running; call err_write.create\(\) before write"):
        nd.write("/err_write/out", Twist())
    nd.create()
    with pytest.raises(errors.NotDeclaredError, match=r"err_write does not publish /elsewhere; declare it first: "
                                                      r"err_write.new.publish\(topic='/elsewhere', msgType=...\)"):
        nd.write("/elsewhere", Twist())
    with pytest.raises(errors.MessageTypeError, match="/err_write/out carries geometry_msgs/Twist, not std_msgs/String"):
        nd.write("/err_write/out", String(data="x"))
    with pytest.raises(errors.MessageTypeError, match="not dict"):
        nd.write("/err_write/out", {"linear": {"x": 1}})


def test_a_rejected_declaration_leaves_the_running_node_alone(make_node):
    seen = []
    nd = make_node("err_keep")
    nd.new.subscribe("/err_keep", handler=seen.append, msgType=UInt32).publish("/err_keep", msgType=UInt32)
    nd.create()
    before = nd.model()
    for bad in (lambda: nd.new.subscribe("/err_keep", handler=print, msgType="std_msgs/Strin"),
                lambda: nd.new.subscribe("/err_keep", handler=lambda a, b: 0, msgType=UInt32),
                lambda: nd.new.publish("/err_keep", msgType=String),
                lambda: nd.remove("/not_there")):
        with pytest.raises(errors.IpyrosError):
            bad()
    assert nd.model() == before
    wait_for(lambda: engine_of(nd).writing.writer("/err_keep")[0].connections(), timeout=20, what="connection")
    nd.write("/err_keep", UInt32(data=7))
    wait_for(lambda: [m.data for m in seen] == [7], what="the old handler to still run")


def test_a_service_or_action_declared_with_two_types_is_one_line(make_node, counting):
    """new and reuse of one service (or action) must agree on its type, as topics must."""
    nd = make_node("err_two_types")
    nd.baseNode("base_exe").basePackage("some_pkg")
    nd.reuse.service("reset", type="std_srvs/Empty")
    with pytest.raises(errors.TopicTypeConflict, match=r"service .*/reset is already declared as reuse.service with "
                                                       r"std_srvs/Empty; use the same type, or remove it first "
                                                       r"\(\w+\.remove\(service='reset'\)\)"):
        nd.new.service("reset", "std_srvs/SetBool", handler=lambda request: None)
    nd.reuse.action("count", type=counting.type)
    other = {"actionlib/Test": "actionlib/TwoInts"}.get(counting.type, "test_msgs/NestedMessage")
    with pytest.raises(errors.TopicTypeConflict, match=r"action .*/count is already declared as reuse.action"):
        nd.new.action("count", other, lambda goal: None)
    assert [s.type for s in nd.model().services] == ["std_srvs/Empty"], "the refused declaration changed nothing"
