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
