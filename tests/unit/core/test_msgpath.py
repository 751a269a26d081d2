"""Message paths (Foxglove's syntax): parsed once, then every value they select in a message, on either ROS's
message shape; a path that names no field says which fields there are, in one line."""

from __future__ import annotations

import pytest
from unit2_msgs.msg import Point
from unit_msgs.msg import Sample, Twist, Vector3

from ipyros.core.msgpath import Field, Filter, Index, MessagePathError, Slice, is_path, parse


def sample() -> Sample:
    return Sample(label="s", gains=[0.5, 1.5, 2.5, 3.5], points=[Vector3(x=-1.0), Vector3(x=2.0, y=1.0),
                                                                 Vector3(x=3.0)], names=["a", "b"])


def test_a_path_is_read_into_its_topic_and_steps():
    path = parse("/poses.points[:]{x>0}.y")
    assert (path.topic, path.field) == ("/poses", "points[:]{x>0}.y")
    assert path.steps == (Field("points"), Slice(None, None), Filter(("x",), ">", 0), Field("y"))
    assert parse("/a/b.c[-1][1:3]").steps == (Field("c"), Index(-1), Slice(1, 3))
    assert parse('/tf.transforms[:]{child_frame_id=="base_link"}').steps[-1] == \
        Filter(("child_frame_id",), "==", "base_link")
    assert parse("/odom{pose.x>$limit}").steps == (Filter(("pose", "x"), ">", "limit", variable=True),)
    assert is_path("/odom.pose") and is_path("/scan[0]") and not is_path("/turtle1/pose")


@pytest.mark.parametrize("text, values", [
    ("/s.label", ["s"]),
    ("/s.gains[0]", [0.5]),
    ("/s.gains[-1]", [3.5]),
    ("/s.gains[9]", []),
    ("/s.gains[1:3]", [1.5, 2.5]),
    ("/s.gains[:]", [0.5, 1.5, 2.5, 3.5]),
    ("/s.points[:].x", [-1.0, 2.0, 3.0]),
    ("/s.points[:]{x>0}.x", [2.0, 3.0]),
    ("/s.points[:]{x>=2}{y==1}.y", [1.0]),
    ("/s.points[:]{x<0}.x", [-1.0]),
    ("/s.points[:]{x!=2.0}.x", [-1.0, 3.0]),
    ("/s{label=='s'}.names[1]", ["b"]),
    ("/s{label=='t'}.names[1]", []),
    ("/s{on==false}.label", ["s"]),
])
def test_a_path_selects_exactly_these_values(text, values):
    assert parse(text).values(sample()) == values


def test_a_filter_on_values_that_have_no_fields_is_one_line():
    with pytest.raises(MessagePathError, match="str has no field 'label'"):
        parse('/s.names[:]{label=="s"}').values(sample())


def test_variables_and_the_other_rosidl_shape():
    assert parse("/p{x>$limit}.y").values(Point(x=2.0, y=7.0), {"limit": 1}) == [7.0]
    assert parse("/p{x>$limit}.y").values(Point(x=2.0, y=7.0), {"limit": 5}) == []
    assert parse("/p.x").values(Point(x=2.0, y=7.0)) == [2.0]


@pytest.mark.parametrize("text, message", [
    ("odom.x", "a message path starts with a topic"),
    ("/odom.", "expected a field name after '.'"),
    ("/odom.a[1", "expected a closing ']'"),
    ("/odom.a[x]", "expected an index"),
    ("/odom{x~1}", "expected a filter such as"),
    ("/odom{x>nope}", r"a number, a quoted string, true, false or a \$variable"),
    ("/odom.a b", "expected '.field'"),
])
def test_a_bad_path_is_refused_in_one_line_saying_where(text, message):
    with pytest.raises(MessagePathError, match=message) as error:
        parse(text)
    assert "\n" not in str(error.value)


def test_a_field_that_is_not_there_says_which_fields_are():
    with pytest.raises(MessagePathError, match=r"/t.linear.w: unit_msgs/Vector3 has no field 'w' \(it has x, y, z\)"):
        parse("/t.linear.w").values(Twist())
    with pytest.raises(MessagePathError, match=r"\[0\] needs an array"):
        parse("/t.linear[0]").values(Twist())
    with pytest.raises(MessagePathError, match=r"no variable \$limit"):
        parse("/t{linear.x>$limit}").values(Twist())


@pytest.mark.parametrize("text", ["/s.label", "/s.points[:]{x>0}.x", "/s{label=='a'}.gains[1:2]", "/s.points[-1].z",
                                  "/s.names[0]"])
def test_a_path_its_type_can_hold_is_checked_quietly(text):
    parse(text).check(Sample)


@pytest.mark.parametrize("text, message", [
    ("/s.nope", "/s.nope: unit_msgs/Sample has no field 'nope' (it has label, on, count, small, level, gains, "),
    ("/s.points.x", "/s.points.x: unit_msgs/Vector3[] is an array: index it or slice it ([0], [:]) before .x"),
    ("/s.label[0]", "/s.label[0]: [0] needs an array, and this is a string"),
    ("/s.label.x", "/s.label.x: a string has no field 'x'"),
    ("/s.points[0]{q>1}", "/s.points[0]{q>1}: unit_msgs/Vector3 has no field 'q' (it has x, y, z)"),
])
def test_a_path_its_type_cannot_hold_is_one_line_before_any_message(text, message):
    with pytest.raises(MessagePathError) as raised:
        parse(text).check(Sample)
    assert str(raised.value).startswith(message) and "\n" not in str(raised.value)


def test_a_path_reads_messages_as_rosbags_gives_them_dataclasses():
    from dataclasses import dataclass

    @dataclass
    class Vec:
        x: float
        y: float

    @dataclass
    class Poses:
        points: list

    assert parse("/p.points[:]{x>0}.y").values(Poses([Vec(1.0, 2.0), Vec(-1.0, 3.0)])) == [2.0]


def test_a_uint8_array_held_as_bytes_is_indexed_and_sliced_to_numbers():
    """ROS 1's genpy gives uint8[] as bytes (ROS 2 a list or an array): /image.data[0:4] is four numbers on both."""
    msg = Sample(raw=bytes([7, 8, 9, 250, 1]))
    assert parse("/s.raw[0:4]").values(msg) == [7, 8, 9, 250]
    assert parse("/s.raw[-1]").values(msg) == [1]
    parse("/s.raw[0]").check_number(Sample)
    with pytest.raises(MessagePathError, match=r"/s.label\[0\]: \[0\] needs an array, and this is a str"):
        parse("/s.label[0]").values(msg)


@pytest.mark.parametrize("text, says", [
    ("/s.label", "/s.label: a string, not a number: a plot draws numbers; name a number field"),
    ("/s.on", "/s.on: a bool, not a number"),
    ("/s.gains", "/s.gains: an array of float64, not a number: a plot draws numbers; index it ([0]) or slice it"),
    ("/s.points[0]", "/s.points[0]: a unit_msgs/Vector3 message, not a number"),
    ("/s.nothing", "/s.nothing: unit_msgs/Sample has no field 'nothing' (it has label, on, count"),
])
def test_a_path_to_plot_must_end_on_a_number(text, says):
    with pytest.raises(MessagePathError) as caught:
        parse(text).check_number(Sample)
    assert str(caught.value).startswith(says), str(caught.value)


def test_numbers_to_plot_pass_and_unknown_types_are_left_to_the_messages():
    for text in ("/s.count", "/s.level", "/s.gains[1]", "/s.points[:].x", "/s.fixed[2]"):
        parse(text).check_number(Sample)
    parse("/s.anything.at_all").check_number(None)


def test_a_paths_steps_as_plain_data_for_an_exported_node_to_walk():
    assert parse("/scan.ranges[0:2]").plain_steps() == (("field", "ranges"), ("slice", 0, 2))
    assert parse("/odom.poses[-1].position.x").plain_steps() == (("field", "poses"), ("index", -1),
                                                                  ("field", "position"), ("field", "x"))
    with pytest.raises(MessagePathError, match="a filter cannot be written as plain steps"):
        parse("/tf.transforms[:]{child_frame_id==\"base\"}").plain_steps()
