#!/usr/bin/python3
"""Test peer: publish std_msgs/UInt32 on TOPIC at 50 Hz; each line "reopen" on stdin closes the
publisher and advertises the topic again at once (what a node restarting a publisher does).

usage: reopen_topic.py TOPIC
Prints "ready" once it publishes, and "reopened N" after the N-th reopen.
"""
import sys
import threading
import time

import rospy
from std_msgs.msg import UInt32

from ipyros.demo.demonode import rospy_node  # ends at once when asked

topic = sys.argv[1]
rospy_node("reopen_topic", anonymous=True, disable_signals=True)
lock = threading.Lock()
pub = rospy.Publisher(topic, UInt32, queue_size=10)


def publish_forever() -> None:
    n = 0
    while not rospy.is_shutdown():
        with lock:
            pub.publish(UInt32(n))
        n += 1
        time.sleep(0.02)


threading.Thread(target=publish_forever, daemon=True).start()
print("ready", flush=True)
reopened = 0
for line in sys.stdin:
    if line.strip() == "reopen":
        with lock:
            pub.unregister()
            pub = rospy.Publisher(topic, UInt32, queue_size=10)
        reopened += 1
        print(f"reopened {reopened}", flush=True)
rospy.signal_shutdown("stdin closed")
