"""Peer: publish std_msgs/UInt32 0..COUNT-1 on TOPIC at RATE Hz once a subscriber matches; print "done"."""
import sys
import time

import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_msgs.msg import UInt32

topic, count, rate = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
rclpy.init()
node = rclpy.create_node("seq_peer")
pub = node.create_publisher(UInt32, topic, QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE))
deadline = time.monotonic() + 20
while pub.get_subscription_count() < 1 and time.monotonic() < deadline:
    time.sleep(0.01)
time.sleep(0.3)  # let the match settle on both sides
print("started", flush=True)
start = time.monotonic()
for i in range(count):
    pub.publish(UInt32(data=i))
    time.sleep(max(0.0, start + (i + 1) / rate - time.monotonic()))
time.sleep(0.5)
print("done", flush=True)
sys.stdin.read()
node.destroy_node()
rclpy.shutdown()
