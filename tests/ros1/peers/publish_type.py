#!/usr/bin/python3
"""Test peer: advertise TOPIC with message TYPE (pkg/Type) and stay up until stdin closes."""
import sys

import roslib.message
import rospy

from ipyros.demo.demonode import rospy_node  # ends at once when asked

topic, type_name = sys.argv[1], sys.argv[2]
rospy_node("publish_type", anonymous=True, disable_signals=True)
pub = rospy.Publisher(topic, roslib.message.get_message_class(type_name), queue_size=1, latch=True)
pub.publish(roslib.message.get_message_class(type_name)())
print("ready", flush=True)
sys.stdin.read()
