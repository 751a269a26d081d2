"""What a message carries is what was meant, on either ROS: an integer in a float field arrives as that float;
anything else that does not fit is refused in one line naming the field, and nothing is sent.

rclpy checks field types only with ROS_PYTHON_CHECK_FIELDS set, and its C conversion reads an
int in a float field as the bits of a double: ``Vector3(x=1)`` arrived as ``x=5e-324``.
"""

from __future__ import annotations

import contextlib

import pytest
from geometry_msgs.msg import Twist, Vector3
from shell import ok
from std_msgs.msg import Float32, Int32, String, UInt8
from std_srvs.srv import SetBool
from support import graph_knows, request_of, response_of, wait_for

from ipyros.core import errors
from ipyros.dsl import engine_of


def one_line(error: BaseException) -> str:
    assert "\n" not in str(error), str(error)
    return str(error)


def connected(nd, topic: str) -> bool:
    return any(f.topic.endswith(topic) and f.connections for f in engine_of(nd).sent())


def test_an_int_in_a_float_field_arrives_as_that_float(make_node, peer):
    listener = peer("listen.py", "/values/vec", "geometry_msgs/Vector3", "x")
    listener.wait_line("ready")
    nd = make_node("values_int").new.publish("/values/vec", msgType=Vector3).create()
    wait_for(lambda: connected(nd, "/values/vec"), timeout=20, what="the listener to connect")
    nd.write("/values/vec", Vector3(x=1, y=2.5))
    assert listener.wait_line("heard") == "heard 1.0"


def test_a_handler_that_builds_a_message_with_an_int_sends_the_float(make_node, peer):
    """The paper's kobuki handler writes what it changed: ``data.linear.x = speed`` with ``speed = 6``."""
    listener = peer("listen.py", "/values/out", "geometry_msgs/Twist", "linear.x")
    listener.wait_line("ready")
    speed = 6
    nd = make_node("values_handler")

    def control(msg):
        msg.linear.x = speed
        nd.write("/values/out", msg)

    nd.new.subscribe("/values/in", handler=control, msgType=Twist).publish("/values/out", msgType=Twist).create()
    feeder = make_node("values_feeder").new.publish("/values/in", msgType=Twist).create()
    wait_for(lambda: connected(nd, "/values/out") and connected(feeder, "/values/in"), timeout=20, what="connections")
    feeder.write("/values/in", Twist())
    assert listener.wait_line("heard") == "heard 6.0"


@pytest.mark.parametrize("msg, field, expected", [
    (Vector3(x="fast"), "x", "a number (float64)"),
    (Int32(data=2**40), "data", "out of range for int32"),
    (Int32(data=1.5), "data", "an integer (int32)"),
    (String(data=5), "data", "a string"),
    # the wire would carry inf on ROS 2 (rclpy converts without a word)
    (Float32(data=1e40), "data", "1e+40 is out of range for float32"),
    (UInt8(data=300), "data", "300 is out of range for uint8 (0..255)"),
])
def test_a_value_that_does_not_fit_is_refused_naming_the_field(make_node, msg, field, expected):
    cls = type(msg)
    nd = make_node("values_refused").new.publish("/values/refused", msgType=cls).create()
    with pytest.raises(errors.MessageTypeError) as caught:
        nd.write("/values/refused", msg)
    text = one_line(caught.value)
    assert f"{field}: " in text and expected in text and "nothing was sent" in text
    nd.write("/values/refused", cls())  # the publication still works


def test_a_nested_message_of_another_type_is_refused_on_ros2(make_node, session):
    """ROS 1 serialises a message by its fields, so a Point where a Vector3 goes is sent as one (the same
    three float64); rclpy's C conversion reads the wrong class, so ROS 2 refuses it."""
    from geometry_msgs.msg import Point

    nd = make_node("values_nested").new.publish("/values/nested", msgType=Twist).create()
    if session.backend.name == "ROS 1":
        nd.write("/values/nested", Twist(linear=Point(x=1.0)))
        return
    with pytest.raises(errors.MessageTypeError, match=r"linear: expected a geometry_msgs/Vector3, got a "
                                                      r"geometry_msgs/Point message"):
        nd.write("/values/nested", Twist(linear=Point()))


def test_a_service_answer_that_does_not_fit_is_reported_naming_the_field(make_node, failures, call):
    nd = make_node("values_service")
    nd.new.service("/values/set", SetBool, handler=lambda request: response_of(SetBool)(success=True, message=5))
    nd.create()
    with contextlib.suppress(Exception):  # ROS 1 answers with an error, ROS 2 with the default response
        call("/values/set", SetBool, request_of(SetBool)(data=True))
    wait_for(lambda: failures, what="the wrong answer reported")
    assert "message: expected a string, got 5 (int)" in str(failures[0].error)


def test_pub_converts_an_int_for_a_float_field(ip, peer):  # noqa: F811 - the ip fixture
    listener = peer("listen.py", "/values/pub", "geometry_msgs/Twist", "linear.x")
    listener.wait_line("ready")
    graph_knows("/values/pub")
    ok(ip, "%pub /values/pub geometry_msgs/Twist {linear: {x: 1}}")
    assert listener.wait_line("heard") == "heard 1.0"


def test_pub_refuses_a_float32_past_its_range_in_one_line(ip):
    """%pub /t std_msgs/Float32 'data: 1e40': ROS 2 would send inf without a word; refused before anything is sent."""
    from shell import error_of

    error = error_of(ip, "%pub /values/f32 std_msgs/Float32 {data: 1.0e+40}")
    assert "data: 1e+40 is out of range for float32 (-3.40282e+38..3.40282e+38)" in one_line(error), str(error)
