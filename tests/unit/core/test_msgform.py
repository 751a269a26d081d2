"""A message type as a form (:mod:`ipyros.core.msgform`), pure: which controls, with which ranges, and the message
built back from their values, on messages of both ROS's shapes."""

from __future__ import annotations

from unit2_msgs.msg import Pose
from unit_msgs.msg import Sample, Twist, Vector3

from ipyros.core.msgform import FormField, form_fields, message_from


def test_numbers_are_sliders_with_a_range_that_holds_their_value():
    fields, left_out = form_fields(Twist, Twist(linear=Vector3(x=25.0)))
    assert [f.path for f in fields] == [f"{part}.{axis}" for part in ("linear", "angular") for axis in "xyz"]
    assert fields[0] == FormField("linear.x", "float", 25.0, -50.0, 50.0, 0.05) and left_out == []
    assert fields[1] == FormField("linear.y", "float", 0.0, -10.0, 10.0, 0.01)


def test_ints_bools_and_strings_get_their_control_and_arrays_are_left_out():
    fields, left_out = form_fields(Sample)
    kinds = {f.path: (f.kind, f.low, f.high) for f in fields}
    assert kinds["label"][0] == "text" and kinds["on"][0] == "bool"
    assert kinds["count"] == ("int", -100, 100) and kinds["small"] == ("int", -100, 100)
    assert kinds["level"][0] == "float"
    assert left_out == ["gains", "fixed", "raw", "points", "names"]


def test_the_message_is_built_back_from_the_values():
    msg = message_from(Twist, {"linear.x": 0.7, "angular.z": -0.2})
    assert (msg.linear.x, msg.angular.z, msg.linear.y) == (0.7, -0.2, 0.0)
    assert message_from(Pose, {f.path: f.value for f in form_fields(Pose)[0]}) == Pose()


def test_a_parameter_is_a_control_in_its_nodes_range_or_one_around_its_value():
    from ipyros.core.msgform import param_field

    assert param_field("/n/gain", 0.5, {"min": 0.0, "max": 2.0}) == FormField("/n/gain", "float", 0.5, 0.0, 2.0, 0.002)
    assert param_field("/n/gain", 40.0, {}) == FormField("/n/gain", "float", 40.0, -80.0, 80.0, 0.16)
    assert param_field("/n/count", 7, {"min": 0, "max": 10, "step": 2}) == FormField("/n/count", "int", 7, 0, 10, 2)
    assert param_field("/n/count", 7, {}) == FormField("/n/count", "int", 7, 0, 100, 1)
    assert param_field("/n/on", True, {}).kind == "bool" and param_field("/n/name", "x", {}).kind == "text"
    assert param_field("/n/list", [1, 2], {}) is None
    assert param_field("/n/gain", 0.5, {"range": "0.0 to 2.0 by 0.5"}) == FormField("/n/gain", "float", 0.5, 0.0, 2.0, 0.5)


def test_a_guards_limits_are_the_ranges_of_their_sliders_and_hold_their_values():
    bounds = {"linear.x": (-0.5, 0.5), "angular.z": (-1.0, 1.0), "linear.q": (0.0, 1.0)}  # no such field: no effect
    fields = {f.path: f for f in form_fields(Twist, Twist(linear=Vector3(x=3.0)), bounds)[0]}
    assert fields["linear.x"] == FormField("linear.x", "float", 0.5, -0.5, 0.5, 0.0005)  # 3.0 would not pass
    assert (fields["angular.z"].low, fields["angular.z"].high, fields["angular.z"].value) == (-1.0, 1.0, 0.0)
    assert (fields["linear.y"].low, fields["linear.y"].high) == (-10.0, 10.0)  # unguarded: as before
    counts = {f.path: f for f in form_fields(Sample, None, {"count": (-2.5, 7.5)})[0]}
    assert (counts["count"].low, counts["count"].high, counts["count"].value) == (-2, 7, 0)
