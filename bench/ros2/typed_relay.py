"""Path (b): a relay as users write one by hand in rclpy (topic_tools for ROS 2 is C++, not on PyPI).

    typed_relay.py IN OUT KIND

A typed subscription whose callback publishes the message on, spun by rclpy's default
single-threaded executor.
"""

from __future__ import annotations

import sys

import rclpy

import common
import wire2

source, target, kind = sys.argv[1:4]
rclpy.init()
node = rclpy.create_node("bench_typed_relay")
cls = wire2.message_class(kind)
pub = node.create_publisher(cls, target, common.QOS)
node.create_subscription(cls, source, pub.publish, common.QOS)
executor = common.spin_in_background(node)
common.say("ready", source)
common.serve()
common.stop(node, executor)
