"""Messages built from data field by field, every value checked, and messages as YAML and back
(:mod:`ipyros.core.msgbuild`), on classes of both ROS's shapes (``tests/unit/msgpkgs``)."""

from __future__ import annotations

import math

import pytest

from ipyros.core import msgbuild
from ipyros.core.errors import MessageTypeError


def test_a_message_from_a_dict_a_list_a_single_value_or_nothing():
    twist = msgbuild.build_message("unit_msgs/Twist", {"linear": {"x": 0.5}})
    assert (twist.linear.x, twist.linear.y, twist.angular.z) == (0.5, 0.0, 0.0)
    assert msgbuild.build_message("unit_msgs/Vector3", [1, 2, 3]).z == 3.0
    assert msgbuild.build_message("unit_msgs/Gain", 2).gain == 2.0
    assert msgbuild.build_message("unit_msgs/Vector3").x == 0.0


def test_an_integer_in_a_float_field_becomes_a_float():
    built = msgbuild.build_message("unit_msgs/Vector3", {"x": 1})
    assert built.x == 1.0 and type(built.x) is float


@pytest.mark.parametrize("data, says", [
    ({"linear": {"q": 1}}, "unit_msgs/Twist: linear.q: no such field (unit_msgs/Vector3 has x, y, z)"),
    ({"linear": {"x": "fast"}}, "linear.x: expected a number (float64), got 'fast' (str)"),
    ({"linear": {"x": True}}, "linear.x: expected a number (float64), got True (bool)"),
    ({"linear": {"x": math.nan}}, "linear.x: nan is not a number a robot can use"),
    ({"angular": {"z": math.inf}}, "angular.z: inf is not a number a robot can use"),
    ({"linear": [1, 2]}, "linear: 2 values for unit_msgs/Vector3, which has 3 fields"),
    ("go", "expected a dict of fields for unit_msgs/Twist (linear, angular), got 'go' (str)"),
])
def test_every_wrong_value_is_named_by_its_path(data, says):
    with pytest.raises(MessageTypeError) as caught:
        msgbuild.build_message("unit_msgs/Twist", data)
    assert says in str(caught.value) and "\n" not in str(caught.value), str(caught.value)


def test_nonfinite_values_pass_only_when_asked():
    assert math.isinf(msgbuild.build_message("unit_msgs/Vector3", {"x": math.inf}, nonfinite=True).x)


@pytest.mark.parametrize("field, value, says", [
    ("count", 2**31, "count: 2147483648 is out of range for int32"),
    ("small", -129, "small: -129 is out of range for int8 (-128..127)"),
    ("count", 1.5, "count: expected an integer (int32), got 1.5 (float)"),
    ("on", 1, "on: expected True or False, got 1 (int)"),
    ("label", 3, "label: expected a string, got 3 (int); quote it"),
    ("fixed", [1, 2], "fixed: expected exactly 3 values (float64[3]), got 2"),
    ("gains", "abc", "gains: expected a list of float64, got 'abc' (str)"),
    ("points", [{"x": 1}, {"w": 2}], "points[1].w: no such field"),
    ("raw", [1, 256], "raw[1]: 256 is out of range for uint8"),
])
def test_each_kind_of_field_is_checked(field, value, says):
    with pytest.raises(MessageTypeError) as caught:
        msgbuild.build_message("unit_msgs/Sample", {field: value})
    assert says in str(caught.value), str(caught.value)


def test_arrays_of_numbers_messages_and_bytes_are_built():
    sample = msgbuild.build_message("unit_msgs/Sample", {"gains": [1, 2.5], "raw": [1, 2], "points": [{"x": 1}],
                                                          "names": ["a"], "fixed": [0, 0, 1]})
    assert sample.gains == [1.0, 2.5] and sample.raw == b"\x01\x02" and sample.points[0].x == 1.0
    assert sample.names == ["a"] and sample.fixed == [0.0, 0.0, 1.0]


def test_ros2_shaped_classes_are_built_from_their_idl_types():
    pose = msgbuild.build_message("unit2_msgs/Pose", {"position": {"x": 2}, "weights": [1, 2], "name": "p"})
    assert (pose.position.x, pose.weights, pose.name) == (2.0, [1.0, 2.0], "p")
    with pytest.raises(MessageTypeError, match="weights: expected a list of float64"):
        msgbuild.build_message("unit2_msgs/Pose", {"weights": 3})


def test_parse_data_reads_a_literal_or_yaml_and_refuses_a_bomb_in_one_line():
    assert msgbuild.parse_data("{'data': 'x'}") == {"data": "x"}
    assert msgbuild.parse_data("{linear: {x: 1}}") == {"linear": {"x": 1}}
    assert msgbuild.parse_data("") is None
    bomb = "a: &a [x, x, x, x, x, x, x, x, x, x]\n" + "".join(
        f"{chr(98 + i)}: &{chr(98 + i)} [{', '.join([f'*{chr(97 + i)}'] * 10)}]\n" for i in range(8))
    with pytest.raises(MessageTypeError) as caught:
        msgbuild.parse_data(bomb)
    assert "\n" not in str(caught.value)


def test_a_message_as_yaml_flat_fields_and_a_template():
    twist = msgbuild.build_message("unit_msgs/Twist", {"linear": {"x": 1.5}})
    assert msgbuild.flow_yaml(twist) == "{linear: {x: 1.5, y: 0.0, z: 0.0}, angular: {x: 0.0, y: 0.0, z: 0.0}}"
    assert msgbuild.to_yaml(msgbuild.build_message("unit2_msgs/Pose", {"name": "p"})).splitlines()[:3] == \
        ["position:", "  x: 0.0", "  y: 0.0"]
    assert list(msgbuild.flat_fields(twist))[:3] == ["linear.x", "linear.y", "linear.z"]
    assert msgbuild.template("unit_msgs/Vector3") == "{x: 0.0, y: 0.0, z: 0.0}"
    assert msgbuild.fields_of(twist) == ["linear", "angular"]


def test_a_definition_as_rosmsg_show_prints_it():
    assert msgbuild.definition("unit_msgs/Twist") == "unit_msgs/Vector3 linear\nunit_msgs/Vector3 angular"
    assert msgbuild.definition("unit_msgs/Twist", expand=True).splitlines()[1] == "  float64 x"
    assert msgbuild.definition("unit_msgs/SetGain") == "float64 gain\n---\nbool ok"
    assert "LIMIT=10" in msgbuild.definition("unit_msgs/Sample")
    assert "sequence" not in msgbuild.definition("unit2_msgs/Pose") and "float64[] weights" in \
        msgbuild.definition("unit2_msgs/Pose")


def test_conform_makes_a_handlers_message_fit_to_send_or_names_the_field():
    from unit_msgs.msg import Sample, Twist, Vector3

    twist = Twist(linear=Vector3(x=1))  # an int in a float field: sent as the float
    assert msgbuild.conform(twist).linear.x == 1.0 and type(twist.linear.x) is float
    for bad, says in ((Twist(linear=Vector3(x="1")), "linear.x: expected a number (float64), got '1' (str)"),
                      (Sample(count=2**40), "count: 1099511627776 is out of range for int32"),
                      (Sample(on="yes"), "on: expected True or False"),
                      (Sample(points=[Vector3(), "p"]), "points[1]: expected a unit_msgs/Vector3"),
                      (Twist(linear=Sample()), "linear: expected a unit_msgs/Vector3, got a unit_msgs/Sample")):
        with pytest.raises(MessageTypeError) as caught:
            msgbuild.conform(bad)
        assert says in str(caught.value) and str(caught.value).endswith("nothing was sent"), str(caught.value)
        assert msgbuild.explain_unsendable(bad) == str(caught.value)
    assert msgbuild.explain_unsendable(Twist()) is None


def test_a_bool_as_0_or_1_is_a_bool():
    from unit_msgs.msg import Sample

    assert msgbuild.conform(Sample(on=1)).on is True


def test_a_message_copy_is_deep_and_equal_on_both_shapes():
    from unit2_msgs.msg import Pose
    from unit_msgs.msg import Sample, Vector3

    from ipyros.core.msgbuild import copy_message

    sample = Sample(label="s", gains=[1.0, 2.0], points=[Vector3(x=1.0)], names=["a"])
    copied = copy_message(sample)
    assert copied == sample and copied is not sample
    copied.points[0].x, copied.gains[0] = 9.0, 9.0
    assert sample.points[0].x == 1.0 and sample.gains[0] == 1.0  # nothing shared
    pose = Pose()
    assert copy_message(pose) == pose and copy_message(pose) is not pose
    assert copy_message([1, 2]) == [1, 2] and copy_message(3) == 3


def test_a_message_copy_shares_nothing_mutable_and_copies_what_its_fields_do_not_declare():
    """The copier made for a class (a straight-line copy of each field): arrays are new lists, nested messages new
    objects, a value of another kind than declared (a list in a number field, a message of another class in a
    nested field, as a bag's own classes are) copied the general way."""
    from unit2_msgs.msg import Pose
    from unit_msgs.msg import Sample, Vector3

    from ipyros.core.msgbuild import copy_message

    odd = Sample(label="s", gains=(1.0, 2.0), fixed=[1.0, 2.0, 3.0], raw=b"\x01\x02", names=["a"],
                 points=[Vector3(x=1.0), Pose()])  # a message of another class in the list
    odd.count = [1, [2]]  # not what the field declares
    copied = copy_message(odd)
    assert copied == odd
    assert copied.fixed is not odd.fixed and copied.names is not odd.names and copied.points is not odd.points
    assert copied.points[0] is not odd.points[0] and copied.points[1] is not odd.points[1]
    assert copied.count == [1, [2]] and copied.count[1] is not odd.count[1]
    copied.fixed[0], copied.names[0], copied.points[1].position.x = 7.0, "b", 7.0
    assert (odd.fixed[0], odd.names[0], odd.points[1].position.x) == (1.0, "a", 0.0)


def test_same_message_says_what_equality_says_field_by_field_on_both_shapes():
    """The comparer made for a class (straight-line over its fields): any field that differs, nested or in an array,
    makes two messages differ; NaN is no more equal to itself than == says; another class is compared by ==."""
    from unit2_msgs.msg import Pose
    from unit_msgs.msg import Sample, Vector3

    from ipyros.core.msgbuild import copy_message, same_message

    sample = Sample(label="s", gains=[1.0, 2.0], fixed=[1.0, 2.0, 3.0], names=["a"], points=[Vector3(x=1.0)])
    assert same_message(sample, copy_message(sample))
    for change in (lambda m: setattr(m, "label", "t"), lambda m: m.gains.__setitem__(1, 2.5),
                   lambda m: m.points[0].__setattr__("x", 1.5), lambda m: m.names.append("b"),
                   lambda m: setattr(m, "count", 1)):
        other = copy_message(sample)
        change(other)
        assert not same_message(sample, other) and not same_message(other, sample) and (other == sample) is False
    pose, other = Pose(), Pose()
    assert same_message(pose, other)
    other.position.x = float("nan")
    assert not same_message(other, copy_message(other)), "NaN is not equal to NaN, as == says"
    assert not same_message(pose, Vector3()) and not same_message(Vector3(), pose)
    assert same_message(3, 3) and not same_message([1], [2])

