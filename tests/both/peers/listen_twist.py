"""Peer: subscribe to TOPIC (geometry_msgs/Twist) and print ``twist <linear.x> <linear.y> <angular.z> <t>`` per
message, ``t`` the monotonic time it came (s).

    python listen_twist.py TOPIC [--name=NODE]
"""
import sys
import time

from anyros import DemoNode, message_class, say

name = next((a.split("=", 1)[1] for a in sys.argv if a.startswith("--name=")), "listen_twist")
node = DemoNode(name)
node.subscribe(sys.argv[1], message_class("geometry_msgs/Twist"),
               lambda m: say("twist", repr(m.linear.x), repr(m.linear.y), repr(m.angular.z), f"{time.monotonic():.4f}"))
print("ready", flush=True)
node.run(10.0, lambda: None)
