"""Peer: a basenode that publishes its status, "ready", once, latched (transient-local on ROS 2), then only spins.

    python status_once.py
"""
from anyros import DemoNode, message_class

node = DemoNode("status_once")
String = message_class("std_msgs/String")
node.publisher("status", String, latch=True).publish(String(data="ready"))
print("ready", flush=True)
node.run(10.0, lambda: None)
