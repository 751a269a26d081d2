#!/usr/bin/python3
"""Test peer: std_msgs/UInt32 0, 1, 2, ... on TOPIC at RATE Hz, and a clean goodbye to the master.

usage: ticker.py TOPIC RATE
Prints "ready" once advertised. On SIGTERM (what Peer.stop sends) it shuts rospy down,
which unregisters its publisher: the shared test master does not keep a dead node
listed under TOPIC for the tests that come after (rospy with disable_signals=True
would otherwise die on SIGTERM without a word to the master).
"""
import signal
import sys
import time

import rospy
from std_msgs.msg import UInt32

from ipyros.demo.demonode import rospy_node  # ends at once when asked

topic, rate = sys.argv[1], float(sys.argv[2])
rospy_node("ticker", anonymous=True, disable_signals=True)
signal.signal(signal.SIGTERM, lambda *_: rospy.signal_shutdown("stopped by the test"))
pub = rospy.Publisher(topic, UInt32, queue_size=100)
print("ready", flush=True)
start = time.monotonic()
count = 0
while not rospy.is_shutdown():
    try:
        pub.publish(UInt32(count))
    except rospy.ROSException:  # closed by the shutdown between the check and the publish
        break
    count += 1
    time.sleep(max(0.0, start + count / rate - time.monotonic()))
