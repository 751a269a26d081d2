"""ROS graph names in plain Python: the rules ROS 1 and ROS 2 share (no ROS package imported)."""

from __future__ import annotations

import pytest

from ipyros.core import names
from ipyros.core.errors import TopicNameError


@pytest.mark.parametrize("name, namespace, node, resolved", [
    ("cmd_vel", "/", "driver", "/cmd_vel"),
    ("cmd_vel", "/robot1", "driver", "/robot1/cmd_vel"),
    ("cmd_vel", "robot1", "driver", "/robot1/cmd_vel"),
    ("/cmd_vel", "/robot1", "driver", "/cmd_vel"),
    ("~status", "/", "driver", "/driver/status"),
    ("~status", "/robot1/", "driver", "/robot1/driver/status"),
    ("a/b", "/robot1", "driver", "/robot1/a/b"),
    ("/", "/robot1", "driver", "/"),
])
def test_resolve_as_ros_resolves(name, namespace, node, resolved):
    assert names.resolve(name, namespace, node) == resolved


@pytest.mark.parametrize("bad", ["", " ", "1abc", "a b", "a-b", "/a/", "a/", "$(eval 1)", 'x"', "a\nb", "a.b", "/a//b"])
def test_illegal_names_are_one_line_errors(bad):
    with pytest.raises(TopicNameError) as caught:
        names.resolve(bad, "/", "n")
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize("not_a_string", [None, 3, b"/x", ["/x"]])
def test_a_name_that_is_not_a_string(not_a_string):
    with pytest.raises(TopicNameError, match="not a string"):
        names.resolve(not_a_string, "/", "n", "service")


@pytest.mark.parametrize("name, ok", [
    ("turtle_control_node", True), ("/turtle", True), ("n1", True), ("1n", False), ("a/b", False),
    ("~n", False), ("bad name", False), ("", False), ("a-b", False),
])
def test_node_names(name, ok):
    if ok:
        assert names.check_node_name(name) == name.strip("/")
    else:
        with pytest.raises(TopicNameError):
            names.check_node_name(name)


@pytest.mark.parametrize("namespace, result", [("/", "/"), ("robot1", "/robot1/"), ("/a/b/", "/a/b/"), ("", "/")])
def test_namespaces(namespace, result):
    assert names.check_namespace(namespace) == result


@pytest.mark.parametrize("bad", ["my robot", "/a/~b", "/1a", 3])
def test_bad_namespaces(bad):
    with pytest.raises(TopicNameError):
        names.check_namespace(bad)


def test_namespace_of_and_join():
    assert names.namespace_of("/a/b") == "/a/"
    assert names.namespace_of("/a") == "/"
    assert names.join("/ns/", "x") == "/ns/x"
    assert names.join("/ns", "/x") == "/x"
    assert names.join("~", "x") == "~x"


def test_default_namespace_follows_ros_namespace(monkeypatch):
    monkeypatch.setenv("ROS_NAMESPACE", "robot7")
    assert names.default_namespace() == "/robot7/"
    monkeypatch.delenv("ROS_NAMESPACE")
    assert names.default_namespace() == "/"


# -- what one ROS adds: names.ROS1, names.ROS2 -----------------------------------------------------

@pytest.mark.parametrize("name", ["/a__b", "a__b", "~x__y"])
def test_ros2_reserves_double_underscores_and_ros1_does_not(name):
    assert names.resolve(name, "/", "n", "topic", names.ROS1)
    with pytest.raises(TopicNameError, match="ROS 2 reserves '__'") as caught:
        names.resolve(name, "/", "n", "topic", names.ROS2)
    assert "\n" not in str(caught.value) and "use a single _" in str(caught.value)


def test_ros2_refuses_a_part_starting_with_a_digit():
    assert names.resolve("/a/1b", "/", "n", "topic", names.ROS1) == "/a/1b"
    with pytest.raises(TopicNameError, match="no part of a name may start with a digit"):
        names.resolve("/a/1b", "/", "n", "topic", names.ROS2)


@pytest.mark.parametrize("length, ok", [(246, True), (247, False), (6_000, False)])
def test_ros2_topic_names_have_rmw_s_length_and_the_error_quotes_a_cut_name(length, ok):
    name = "/" + "a" * length  # 1 + length characters
    if ok:
        assert names.resolve(name, "/", "n", "topic", names.ROS2) == name
        return
    with pytest.raises(TopicNameError) as caught:
        names.resolve(name, "/", "n", "topic", names.ROS2)
    text = str(caught.value)
    assert f"is {length + 1:,} characters; ROS 2 allows 247" in text and len(text) < 300, text
    assert names.resolve(name, "/", "n", "topic", names.ROS1) == name  # ROS 1 has no such limit


def test_ros2_node_names_and_namespaces_have_rmw_s_lengths():
    assert names.check_node_name("n" * 255, names.ROS2)
    for bad in ("n" * 256, "n" * 5_000):
        with pytest.raises(TopicNameError, match="ROS 2 allows 255") as caught:
            names.check_node_name(bad, names.ROS2)
        assert len(str(caught.value)) < 300
    assert names.check_node_name("n" * 5_000, names.ROS1)
    assert names.check_namespace("/" + "a" * 244, names.ROS2)
    with pytest.raises(TopicNameError, match="ROS 2 allows 245") as caught:
        names.check_namespace("/" + "a" * 3_000, names.ROS2)
    assert len(str(caught.value)) < 300
    with pytest.raises(TopicNameError, match="reserves '__'"):
        names.check_node_name("a__b", names.ROS2)


@pytest.mark.parametrize("check", [lambda v: names.resolve(v, "/", "n"), names.check_node_name, names.check_namespace])
def test_a_long_illegal_value_is_quoted_cut_with_its_size(check):
    with pytest.raises(TopicNameError) as caught:
        check("-" * 5_000)
    assert "(5,002 characters)" in str(caught.value) and len(str(caught.value)) < 300, str(caught.value)
