"""Peer: a basenode gone wrong: publish Twist on TOPIC at RATE Hz, linear.x and angular.z cycling through values out
of any sane limit, NaN, infinities, huge ones, negative zero and the wrong sign; ``sent <n>`` every 20 messages.

    python hostile_cmd.py TOPIC RATE
"""
import math
import sys

from anyros import DemoNode, message_class

topic, rate = sys.argv[1], float(sys.argv[2])
HOSTILE = [0.2, 3.0, -3.0, math.nan, math.inf, -math.inf, 1e308, -1e308, -0.0, 0.4999, 0.5001, -7.5]
node = DemoNode("hostile_cmd")
Twist = message_class("geometry_msgs/Twist")
publisher = node.publisher(topic, Twist)
count = [0]


def send() -> None:
    msg = Twist()
    msg.linear.x = HOSTILE[count[0] % len(HOSTILE)]
    msg.angular.z = HOSTILE[(count[0] * 5 + 1) % len(HOSTILE)]
    publisher.publish(msg)
    count[0] += 1
    if count[0] % 20 == 0:
        print("sent", count[0], flush=True)


print("ready", flush=True)
node.run(rate, send)
