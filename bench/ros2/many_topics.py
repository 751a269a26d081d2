"""The completion bench's ROS 2 peer: N topics, PREFIX0000 ... (std_msgs/String), published by M nodes.

    many_topics.py N PREFIX [M]

A robot's graph of 10,000 topics is hundreds of nodes with a few dozen topics each, not one
node with all of them: the topics are dealt out to M nodes (``bench_topics_000`` ...; default
one node), each a full rclpy node (parameter services, /rosout) as a robot's would be.
Says ``ready`` once every publisher is made, and spins until its input closes.
"""

from __future__ import annotations

import sys

import rclpy
from rclpy.executors import SingleThreadedExecutor
from std_msgs.msg import String

import common

count, prefix = int(sys.argv[1]), sys.argv[2]
nodes_wanted = int(sys.argv[3]) if len(sys.argv) > 3 else 1
rclpy.init()
nodes = [rclpy.create_node(f"bench_topics_{n:03d}" if nodes_wanted > 1 else "bench_topics", start_parameter_services=nodes_wanted == 1)
         for n in range(nodes_wanted)]
width = max(4, len(str(count - 1)))  # as the bench names them (bench/completion.py topic())
publishers = [nodes[i % len(nodes)].create_publisher(String, f"{prefix}{i:0{width}d}", 1) for i in range(count)]
executor = SingleThreadedExecutor()
for node in nodes[1:]:
    executor.add_node(node)
common.spin_in_background(nodes[0], executor)
common.say("ready")
common.serve()
executor.shutdown()
for node in nodes:
    node.destroy_node()
rclpy.try_shutdown()
