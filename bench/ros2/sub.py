"""The bench's subscriber: raw bytes on TOPIC; for each, the index and the one-way latency.

    sub.py TOPIC KIND [reliable|best_effort]

Commands: ``publishers`` (how many publishers match), ``count``, ``report PACED WARMUP WINDOW``
(a JSON line: latencies of paced messages after the warm-up, messages of the first WINDOW
missing, paced and flat-out received, the flat-out rate, whether the last message was handled).
"""

from __future__ import annotations

import json
import sys
import time

import rclpy
from rclpy.serialization import deserialize_message

import common
import wire2

topic, kind = sys.argv[1:3]
reliability = sys.argv[3] if len(sys.argv) > 3 else "reliable"
rclpy.init()
node = rclpy.create_node("bench_sub")
arrived: list[tuple[int, float, float]] = []  # index, latency s, arrival (monotonic)
last: list[bytes] = []


def on_message(raw: bytes) -> None:
    now, mono = time.time(), time.monotonic()
    index, stamp = wire2.read(raw)
    arrived.append((index, now - stamp, mono))
    last[:] = [raw]


sub = node.create_subscription(wire2.message_class(kind), topic, on_message, common.qos(reliability), raw=True)
executor = common.spin_in_background(node)


def report(args: list[str]) -> str:
    paced, warmup, window = map(int, args)
    seen = {i for i, _, _ in arrived}
    latency = [lat * 1000 for i, lat, _ in arrived if warmup <= i < paced]
    flat = [t for i, _, t in arrived if i >= paced]
    handled = False
    if last:
        handled = wire2.KINDS[kind][3](deserialize_message(last[0], wire2.message_class(kind)))
    return json.dumps({"latency_ms": latency, "start_lost": sum(1 for i in range(window) if i not in seen),
                       "paced_received": sum(1 for i in seen if i < paced),
                       "flat_received": len(flat),
                       "flat_per_s": (len(flat) - 1) / (flat[-1] - flat[0]) if len(flat) > 1 and flat[-1] > flat[0] else 0.0,
                       "handled": handled})


common.say("ready")
common.serve({"publishers": lambda _: sub.get_publisher_count(), "count": lambda _: len(arrived), "report": report})
common.stop(node, executor)
