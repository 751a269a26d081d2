#!/usr/bin/python3
"""Test peer: publish sensor_msgs/Image on TOPIC, image i (from 1) with frame_id "i" and every data byte
i % 251, so that a subscriber can tell a whole image from a broken one (check_images.py).

usage: publish_images.py TOPIC [--size BYTES] [--rate HZ] [--count N] [--first I] [--when-heard]
Prints "ready" once advertised; publishes COUNT images (0: until stdin closes) at RATE Hz, with
--when-heard from when a subscriber is connected.
"""
import argparse
import sys
import threading

import rospy
from sensor_msgs.msg import Image

from ipyros.demo.demonode import rospy_node  # ends at once when asked

parser = argparse.ArgumentParser()
parser.add_argument("topic")
parser.add_argument("--size", type=int, default=1 << 20)
parser.add_argument("--rate", type=float, default=20.0)
parser.add_argument("--count", type=int, default=0)
parser.add_argument("--first", type=int, default=1, help="the first image's i")
parser.add_argument("--when-heard", action="store_true")
args, _ = parser.parse_known_args(rospy.myargv()[1:])
rospy_node("publish_images", anonymous=True, disable_signals=True)
pub = rospy.Publisher(args.topic, Image, queue_size=None)
stop = threading.Event()
threading.Thread(target=lambda: (sys.stdin.read(), stop.set()), daemon=True).start()
print("ready", flush=True)
while args.when_heard and pub.get_num_connections() == 0 and not stop.wait(0.01):
    pass
i = args.first - 1
while not stop.is_set() and (args.count == 0 or i < args.first - 1 + args.count):
    i += 1
    pub.publish(Image(height=1, width=args.size, encoding="mono8", step=args.size,
                      data=bytes([i % 251]) * args.size, header=rospy.Header(frame_id=str(i))))
    stop.wait(1.0 / args.rate)
