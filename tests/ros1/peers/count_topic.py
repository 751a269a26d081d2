#!/usr/bin/python3
"""Test peer: print "got N" for each message on TOPIC (TYPE pkg/Type); ``--sleep S`` makes its
callback take S seconds, as a subscriber that cannot keep up (rospy calls it on the connection's
reading thread, so the socket backs up to the publisher)."""
import argparse
import sys
import time

import roslib.message
import rospy

from ipyros.demo.demonode import rospy_node  # ends at once when asked

parser = argparse.ArgumentParser()
parser.add_argument("topic")
parser.add_argument("type")
parser.add_argument("--sleep", type=float, default=0.0)
args, _ = parser.parse_known_args(rospy.myargv()[1:])
rospy_node("count_topic", anonymous=True, disable_signals=True)
count = 0


def got(msg):
    global count
    count += 1
    print(f"got {count}", flush=True)
    if args.sleep:
        time.sleep(args.sleep)


rospy.Subscriber(args.topic, roslib.message.get_message_class(args.type), got,
                 buff_size=1 << 20 if args.sleep else 65536)
print("ready", flush=True)
sys.stdin.read()
