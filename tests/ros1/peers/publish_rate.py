#!/usr/bin/python3
"""Test peer: publish std_msgs/UInt32 0, 1, 2, ... on TOPIC at RATE Hz from the start, until stopped.

usage: publish_rate.py TOPIC RATE
Prints "ready" once advertised. Unlike publish_seq.py it does not wait for subscribers:
it is a steady source, like a sensor.
"""
import sys
import time

import rospy
from std_msgs.msg import UInt32

from ipyros.demo.demonode import rospy_node  # ends at once when asked

topic, rate = sys.argv[1], float(sys.argv[2])
rospy_node("publish_rate", anonymous=True, disable_signals=True)
pub = rospy.Publisher(topic, UInt32, queue_size=100)
print("ready", flush=True)
period, i = 1.0 / rate, 0
start = time.monotonic()
while True:
    pub.publish(UInt32(i))
    i += 1
    time.sleep(max(0.0, start + i * period - time.monotonic()))
