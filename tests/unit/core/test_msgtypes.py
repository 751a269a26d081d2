"""Message, service and action types by class or by name, and the one-line errors for the ones not there
(:mod:`ipyros.core.msgtypes`), on classes of both ROS's shapes."""

from __future__ import annotations

import pytest

from ipyros.core import msgtypes
from ipyros.core.errors import MessageTypeError


def test_a_type_by_name_in_either_spelling_and_by_class():
    from unit2_msgs.msg import Pose
    from unit_msgs.msg import Twist

    assert msgtypes.resolve_message("unit_msgs/Twist") == ("unit_msgs/Twist", Twist)
    assert msgtypes.resolve_message("unit_msgs/msg/Twist") == ("unit_msgs/Twist", Twist)
    assert msgtypes.resolve_message(Twist) == ("unit_msgs/Twist", Twist)
    assert msgtypes.resolve_message("unit2_msgs/Pose") == ("unit2_msgs/Pose", Pose)
    assert msgtypes.type_name(Pose()) == "unit2_msgs/Pose" and msgtypes.type_name(Twist()) == "unit_msgs/Twist"


def test_a_service_type():
    from unit_msgs.srv import SetGain

    assert msgtypes.resolve_service("unit_msgs/SetGain") == ("unit_msgs/SetGain", SetGain)
    assert msgtypes.is_service(SetGain) and not msgtypes.is_service(msgtypes.resolve_message("unit_msgs/Twist")[1])


@pytest.mark.parametrize("spec, says", [
    ("unit_msgs/Twst", "package 'unit_msgs' has no 'Twst'; did you mean unit_msgs/Twist?"),
    ("unit_msg/Twist", "unknown message package 'unit_msg'"),
    ("Twist", "malformed message type 'Twist': write 'package/Type'"),
    ("unit_msgs/Twist/x", "malformed message type"),
    ("unit_msgs/SetGain", "'unit_msgs/SetGain' is a service type, not a message type"),
    (3, "message type must be a class or a 'pkg/Type' string, not int"),
    (None, "no message type given; pass msgType=..."),
    (dict, "dict is not a ROS message class"),
])
def test_a_type_that_is_not_there_is_one_line_naming_what_is(spec, says):
    with pytest.raises(MessageTypeError) as caught:
        msgtypes.resolve_message(spec)
    assert says in str(caught.value) and "\n" not in str(caught.value), str(caught.value)


def test_a_message_where_a_service_goes_says_so():
    with pytest.raises(MessageTypeError, match="is a message type, not a service type"):
        msgtypes.resolve_service("unit_msgs/Twist")


def test_the_packages_on_the_path_are_listed():
    assert {"unit_msgs/Twist", "unit_msgs/Vector3", "unit_msgs/Sample", "unit2_msgs/Pose"} <= \
        set(msgtypes.known_message_types())
    assert "unit_msgs/SetGain" in msgtypes.known_service_types()


@pytest.mark.parametrize("name, short", [("std_msgs/msg/String", "std_msgs/String"), ("std_msgs/String",
                                         "std_msgs/String"), ("a/action/B", "a/B")])
def test_short_names(name, short):
    assert msgtypes.short_name(name) == short


def test_not_installed_names_what_to_install_for_each_missing_type():
    missing = msgtypes.not_installed(["unit_msgs/Twist", "nav_msgs/Odometry", "", "nav_msgs/Odometry"])
    assert list(missing) == ["nav_msgs/Odometry"] and "nav-msgs" in missing["nav_msgs/Odometry"]


def test_a_package_name_from_its_manifest(tmp_path):
    (tmp_path / "folder").mkdir()
    (tmp_path / "folder" / "package.xml").write_text("<package><name>real_name</name></package>")
    assert msgtypes.package_name_of(tmp_path / "folder") == "real_name"
    (tmp_path / "bare").mkdir()
    assert msgtypes.package_name_of(tmp_path / "bare") == "bare"


def test_an_action_type_that_is_not_there():
    with pytest.raises(MessageTypeError, match="unknown action type 'unit_msgs/Nope'"):
        msgtypes.resolve_action("unit_msgs/Nope")
    with pytest.raises(MessageTypeError, match="no action type given"):
        msgtypes.resolve_action(None)


def test_a_peer_of_another_type_is_told_in_the_same_words_on_both_ros():
    from ipyros.core.msgtypes import another_type_line

    line = another_type_line("/cmd", "/teleop", "geometry_msgs/Twist", "std_msgs/String", "ROS 2")
    assert line == ("/cmd: /teleop publishes geometry_msgs/Twist there, and this node subscribes to it as "
                    "std_msgs/String: nothing passes between them (ROS 2 connects no two types); subscribe with "
                    "msgType='geometry_msgs/Twist', or publish std_msgs/String")
