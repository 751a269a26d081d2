"""Building messages from plain data with strict checks: every mistake names its field."""

from __future__ import annotations

import genpy
import pytest
from geometry_msgs.msg import Twist, Vector3
from sensor_msgs.msg import Image
from std_msgs.msg import String

from ipyros.core.errors import MessageTypeError
from ipyros.core.msgbuild import build_message, parse_data


def test_nested_dict_fills_the_fields_given_and_keeps_defaults_for_the_rest():
    msg = build_message("geometry_msgs/Twist", {"linear": {"x": 0.5}, "angular": {"z": -1}})
    assert isinstance(msg, Twist)
    assert (msg.linear.x, msg.linear.y, msg.angular.z) == (0.5, 0.0, -1.0)
    assert isinstance(msg.angular.z, float)


def test_a_class_a_list_of_all_fields_and_a_single_value():
    assert build_message(Vector3, [1, 2, 3]) == Vector3(1.0, 2.0, 3.0)
    assert build_message("std_msgs/String", "hello") == String("hello")
    assert build_message("std_msgs/String") == String()
    given = Twist()
    assert build_message(Twist, given) is given


def test_arrays_times_and_bytes():
    msg = build_message("sensor_msgs/Image", {"header": {"stamp": 1.5, "frame_id": "cam"}, "data": [1, 2, 255],
                                              "height": 1})
    assert isinstance(msg, Image) and msg.data == b"\x01\x02\xff"
    assert msg.header.stamp == genpy.Time(1, 500_000_000)
    assert build_message("std_msgs/Time", {"data": {"secs": 3, "nsecs": 7}}).data == genpy.Time(3, 7)
    assert build_message("std_msgs/Time", "now").data.to_sec() > 1e9
    assert build_message("geometry_msgs/PoseArray", {"poses": [{"position": {"x": 1}}, {}]}).poses[0].position.x == 1.0


@pytest.mark.parametrize("data, expected", [
    ({"linear": {"q": 1}}, "geometry_msgs/Twist: linear.q: no such field (geometry_msgs/Vector3 has x, y, z)"),
    ({"speed": 1}, "geometry_msgs/Twist: speed: no such field (geometry_msgs/Twist has linear, angular)"),
    ({"linear": {"x": "fast"}}, "linear.x: expected a number (float64), got 'fast' (str)"),
    ({"linear": {"x": True}}, "linear.x: expected a number (float64), got True (bool)"),
    ({"linear": 3}, "linear: expected a dict of fields for geometry_msgs/Vector3 (x, y, z), got 3 (int)"),
    ([1, 2], "linear: expected a dict of fields for geometry_msgs/Vector3 (x, y, z), got 1 (int)"),
])
def test_mistakes_are_errors_naming_the_field(data, expected):
    with pytest.raises(MessageTypeError) as caught:
        build_message("geometry_msgs/Twist", data)
    assert expected in str(caught.value)


@pytest.mark.parametrize("type_name, data, expected", [
    ("std_msgs/UInt8", 256, "data: 256 is out of range for uint8 (0..255)"),
    ("std_msgs/Int8", -129, "data: -129 is out of range for int8 (-128..127)"),
    ("std_msgs/Int32", 1.5, "data: expected an integer (int32), got 1.5 (float)"),
    ("std_msgs/String", 5, "data: expected a string, got 5 (int); quote it"),
    ("std_msgs/Bool", 1, "data: expected True or False, got 1 (int)"),
    ("geometry_msgs/Vector3", [1, 2], "2 values for geometry_msgs/Vector3, which has 3 fields (x, y, z)"),
    ("geometry_msgs/Vector3", 7, "expected a dict of fields for geometry_msgs/Vector3 (x, y, z), got 7"),
    ("sensor_msgs/Image", {"data": [1, 300]}, "data[1]: 300 is out of range for uint8"),
    ("sensor_msgs/Image", {"header": {"stamp": "yesterday"}}, "header.stamp: expected seconds"),
    ("geometry_msgs/PoseArray", {"poses": [{"position": {"w": 1}}]}, "poses[0].position.w: no such field"),
    ("geometry_msgs/PoseArray", {"poses": {"x": 1}}, "poses: expected a list of geometry_msgs/Pose"),
    ("geometry_msgs/Twist", Vector3(), "expected a geometry_msgs/Twist, got a geometry_msgs/Vector3"),
])
def test_each_kind_of_field_is_checked(type_name, data, expected):
    with pytest.raises(MessageTypeError) as caught:
        build_message(type_name, data)
    assert expected in str(caught.value)
    assert str(caught.value).startswith(type_name + ":")


def test_unknown_types_are_errors_with_a_suggestion():
    with pytest.raises(MessageTypeError, match="did you mean geometry_msgs/Twist"):
        build_message("geometry_msgs/Twst", {})


def test_fixed_size_arrays_must_have_their_size():
    msg = build_message("geometry_msgs/PoseWithCovariance", {"covariance": [0.0] * 36})
    assert len(msg.covariance) == 36
    with pytest.raises(MessageTypeError, match=r"covariance: expected exactly 36 values \(float64\[36\]\), got 2"):
        build_message("geometry_msgs/PoseWithCovariance", {"covariance": [1, 2]})


def test_parse_data_reads_python_literals_then_yaml():
    assert parse_data("") is None
    assert parse_data("{'data': None}") == {"data": None}  # Python's None, not the string "None"
    assert parse_data("{linear: {x: 1.0}}") == {"linear": {"x": 1.0}}
    assert parse_data("linear:\n  x: 1\nangular: {z: 2}") == {"linear": {"x": 1}, "angular": {"z": 2}}
    assert parse_data("hello world") == "hello world"
    assert parse_data("[1, 2, 3]") == [1, 2, 3]
    with pytest.raises(MessageTypeError, match=r"the message data is not valid YAML at line 1, column \d+"):
        parse_data("{a: [1,")
