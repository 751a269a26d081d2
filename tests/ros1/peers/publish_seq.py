#!/usr/bin/python3
"""Test peer: publish std_msgs/UInt32 0..N-1 on TOPIC at RATE Hz, once a subscriber is connected.

usage: publish_seq.py TOPIC COUNT RATE [MIN_SUBSCRIBERS]
Prints "started" when it begins publishing and "done" at the end.
"""
import sys
import time

import rospy
from std_msgs.msg import UInt32

from ipyros.demo.demonode import rospy_node  # ends at once when asked

topic, count, rate = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
subscribers = int(sys.argv[4]) if len(sys.argv) > 4 else 1
rospy_node("publish_seq", anonymous=True, disable_signals=True)
pub = rospy.Publisher(topic, UInt32, queue_size=count)
deadline = time.monotonic() + 30
while pub.get_num_connections() < subscribers and time.monotonic() < deadline:
    time.sleep(0.01)
time.sleep(0.2)  # let the subscriber side finish its handshake
print("started", flush=True)
period = 1.0 / rate
start = time.monotonic()
for i in range(count):
    pub.publish(UInt32(i))
    time.sleep(max(0.0, start + (i + 1) * period - time.monotonic()))
time.sleep(0.5)
print("done", flush=True)
