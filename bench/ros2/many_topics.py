"""The completion bench's ROS 2 peer: one node that publishes N topics, PREFIX0000 ... (std_msgs/String).

    many_topics.py N PREFIX

Says ``ready`` once every publisher is made, and spins until its input closes.
"""

from __future__ import annotations

import sys

import rclpy
from std_msgs.msg import String

import common

count, prefix = int(sys.argv[1]), sys.argv[2]
rclpy.init()
node = rclpy.create_node("bench_topics")
width = max(4, len(str(count - 1)))  # as the bench names them (bench/completion.py topic())
publishers = [node.create_publisher(String, f"{prefix}{i:0{width}d}", 1) for i in range(count)]
executor = common.spin_in_background(node)
common.say("ready")
common.serve()
common.stop(node, executor)
