"""The bench's publisher: serialized messages on TOPIC, paced, then flat out.

    pub.py TOPIC KIND [reliable|best_effort]

``go RATE PACED FLAT``: wait for a subscription to match, publish PACED messages at RATE Hz
(indices 0..PACED-1), say ``paced``, then FLAT as fast as rclpy takes them, say ``flat SENT``.
"""

from __future__ import annotations

import sys
import time

import rclpy
from rclpy._rclpy_pybind11 import RCLError

import common
import wire2

topic, kind = sys.argv[1:3]
reliability = sys.argv[3] if len(sys.argv) > 3 else "reliable"
rclpy.init()
node = rclpy.create_node("bench_pub")
pub = node.create_publisher(wire2.message_class(kind), topic, common.qos(reliability))
buff = wire2.template(kind)


def go(args: list[str]) -> str:
    rate, paced, flat = float(args[0]), int(args[1]), int(args[2])
    deadline = time.monotonic() + 20
    while pub.get_subscription_count() < 1:
        if time.monotonic() > deadline:
            return "error no subscription matched in 20 s"
        time.sleep(0.001)
    start = time.monotonic()
    for i in range(paced):
        wire2.mark(buff, i, time.time())
        pub.publish(bytes(buff))
        time.sleep(max(0.0, start + (i + 1) / rate - time.monotonic()))
    time.sleep(0.5)
    common.say("paced")
    refused = 0
    for i in range(paced, paced + flat):
        wire2.mark(buff, i, time.time())
        while True:
            try:
                pub.publish(bytes(buff))
                break
            except RCLError:  # Fast DDS: the reliable history is full and the reader is behind
                refused += 1
                time.sleep(0.001)
    return f"flat {flat} refused {refused}"


common.say("ready")
common.serve({"go": go})
node.destroy_node()
rclpy.try_shutdown()
