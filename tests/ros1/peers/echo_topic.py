#!/usr/bin/python3
"""Test peer: print each message on TOPIC (TYPE pkg/Type) as one line of YAML-ish text."""
import sys

import roslib.message
import rospy

from ipyros.demo.demonode import rospy_node  # ends at once when asked

topic, type_name = sys.argv[1], sys.argv[2]
rospy_node("echo_topic", anonymous=True, disable_signals=True)


def show(msg):
    print(repr(msg).replace("\n", " "), flush=True)


rospy.Subscriber(topic, roslib.message.get_message_class(type_name), show)
print("ready", flush=True)
sys.stdin.read()
