"""ROS 2's name rules are stricter than ROS 1's (a token may not start with a digit): refused where the name is
given, in one line."""

from __future__ import annotations

import pytest
from std_msgs.msg import String

from ipyros.core import errors
from ipyros.dsl import engine_of


def test_a_namespace_rclpy_refuses_is_one_line(make_node):
    with pytest.raises(errors.DeclarationError) as caught:
        make_node("digits", namespace="/robot/1st").create()
    text = str(caught.value)
    assert "\n" not in text and text.startswith("invalid namespace name '/robot/1st': in ROS 2 no part of a name may "
                                               "start with a digit"), text


def test_a_topic_rclpy_refuses_is_one_line(make_node):
    nd = make_node("digit_topic").create()
    with pytest.raises(errors.DeclarationError) as caught:
        nd.new.publish("/robot/1st/out", msgType=String)
    text = str(caught.value)
    assert "\n" not in text and text.startswith("invalid topic name '/robot/1st/out': in ROS 2 no part of a name "
                                               "may start with a digit"), text
    assert nd.model().topics == []


def test_a_peer_whose_node_discovery_has_not_told_is_not_called_unknown():
    """rclpy names such a peer _NODE_NAMESPACE_UNKNOWN_/_NODE_NAME_UNKNOWN_: the QoS notice waits a moment for
    discovery, then says the node is not known yet rather than print the placeholder."""
    from ipyros.ros2.qosmatch import peer_name

    assert peer_name("/robot1", "lidar") == "/robot1/lidar"
    assert peer_name("/", "lidar") == "/lidar"
    assert peer_name("_NODE_NAMESPACE_UNKNOWN_", "_NODE_NAME_UNKNOWN_") is None


def test_a_namesake_another_process_started_a_moment_before_is_said_not_accepted_silently(make_node, peer, notices,
                                                                                           monkeypatch):
    """Another process's node of the same name that discovery had not shown when the name was checked (made sure
    here by letting the check see nothing, as in the race the hostile round found): the session says, in one line,
    that two nodes now share the name."""
    from support import wait_for

    other = peer("talk.py", "/namesake/out", "std_msgs/String", "5", "--ros-args", "-r", "__node:=namesake")
    other.wait_line("ready")
    nd = make_node("namesake")
    backend = engine_of(nd).session.backend
    wait_for(lambda: "/namesake" in backend.graph_snapshot().nodes, timeout=30, what="the other node discovered")
    monkeypatch.setattr(type(backend), "refuse_taken_name", lambda self, name: None)
    nd.create()
    said = "ipyros: namesake: a second node named /namesake showed up in the ROS 2 graph (ROS_DOMAIN_ID "
    wait_for(lambda: any(n.startswith(said) for n in notices), timeout=10, what="the namesake to be said")
    told = [n for n in notices if n.startswith(said)]
    assert len(told) == 1 and "two nodes now share the name" in told[0] and "\n" not in told[0], told
