#!/usr/bin/python3
"""Test peer: subscribe to sensor_msgs/Image on TOPIC and check each image as publish_images.py makes them:
prints "got N ID" for a whole one (N counts them, ID is its frame_id), "broken ID" for one whose bytes
are not all ID % 251."""
import sys

import rospy
from sensor_msgs.msg import Image

from ipyros.demo.demonode import rospy_node  # ends at once when asked

rospy_node("check_images", anonymous=True, disable_signals=True)
count = 0


def check(msg: Image) -> None:
    global count
    ident = int(msg.header.frame_id)
    if msg.data and len(msg.data) == msg.step * msg.height and msg.data == bytes([ident % 251]) * len(msg.data):
        count += 1
        print(f"got {count} {ident}", flush=True)
    else:
        print(f"broken {ident}", flush=True)


rospy.Subscriber(sys.argv[1], Image, check, buff_size=1 << 22)
print("ready", flush=True)
sys.stdin.read()
