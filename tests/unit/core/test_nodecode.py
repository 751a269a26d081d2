"""The name a node's Python source gives its node, read and never run (core/nodecode.py)."""

from __future__ import annotations

import pytest

from ipyros.core.nodecode import entry_point_of, node_name_in

ROS1 = {"init_node"}
ROS2 = {"create_node", "Node", "LifecycleNode"}


@pytest.mark.parametrize("source, calls, name", [
    ('import rospy\nrospy.init_node("talker")', ROS1, "talker"),
    ('from rospy import init_node\ninit_node(name="talker", anonymous=True)', ROS1, "talker"),
    ('NAME = "talker"\nimport rospy\nrospy.init_node(NAME)', ROS1, "talker"),
    ('node = rclpy.create_node("talker")', ROS2, "talker"),
    ('node = Node(node_name="talker", namespace="ns")', ROS2, "talker"),
    ('class T(Node):\n    def __init__(self):\n        super().__init__("talker")', ROS2, "talker"),
    ('class T(rclpy.lifecycle.LifecycleNode):\n    def __init__(self):\n        LifecycleNode.__init__(self, "lc")',
     ROS2, "lc"),
    ('rclpy.init()\nn = Node("/talker")', ROS2, "talker"),
])
def test_a_literal_name_is_found(source, calls, name):
    assert node_name_in(source, calls) == name


@pytest.mark.parametrize("source, calls", [
    ('rospy.init_node("a")\nrospy.init_node("b")', ROS1),  # several: which one runs is not read from the text
    ('rospy.init_node("talker_" + suffix)', ROS1),  # computed
    ('NAME = "a"\nNAME = "b"\nrospy.init_node(NAME)', ROS1),  # not a constant
    ('rospy.init_node("my node")', ROS1),  # not a node name
    ('node = Node("talker")', ROS1),  # another ROS's call
    ('class T(Other):\n    def __init__(self):\n        super().__init__("talker")', ROS2),
    ('def broken(:\n', ROS1),
    ('\x00', ROS1),
])
def test_anything_else_gives_none(source, calls):
    assert node_name_in(source, calls) is None


@pytest.mark.parametrize("source, entry", [
    ("import sys\nfrom demo_nodes_py.topics.talker import main\nsys.exit(main())",
     ("module", "demo_nodes_py.topics.talker")),
    ("import re, sys\nif __name__ == '__main__':\n    sys.exit(load_entry_point('demo-nodes-py==0.20.3', "
     "'console_scripts', 'talker')())", ("console_scripts", "demo-nodes-py/talker")),
    ("import rospy\nrospy.init_node('x')", None),
    ("from a import main\nfrom b import main", None),  # which one runs is not read from the text
])
def test_an_entry_point_script_says_what_it_runs(source, entry):
    assert entry_point_of(source) == entry
