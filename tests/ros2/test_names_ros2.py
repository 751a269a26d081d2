"""ROS 2's name rules are stricter than ROS 1's (a token may not start with a digit): refused where the name is
given, in one line."""

from __future__ import annotations

import pytest
from std_msgs.msg import String

from ipyros.core import errors


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
    from ipyros.ros2.runtime import peer_name

    assert peer_name("/robot1", "lidar") == "/robot1/lidar"
    assert peer_name("/", "lidar") == "/lidar"
    assert peer_name("_NODE_NAMESPACE_UNKNOWN_", "_NODE_NAME_UNKNOWN_") is None
