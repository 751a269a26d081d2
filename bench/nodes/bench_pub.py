"""The bench's publisher: a paced stream, then a flat-out burst, of pre-serialized messages.

    bench_pub.py TOPIC KIND RATE_HZ RATE_COUNT FLAT_COUNT

It advertises TOPIC with the concrete class (so type, md5 and definition are right),
waits until a subscriber is connected (``get_num_connections() > 0``) and starts the
paced stream at once: loss at the start of a stream is counted from that moment.
Messages 0 .. RATE_COUNT-1 are paced at RATE_HZ; the publisher then says ``rate-done``
and waits for ``go``; messages RATE_COUNT .. RATE_COUNT+FLAT_COUNT-1 are written as
fast as the connection takes them, then it says ``flat-done SECONDS START_NS`` (how
long the writes took, and the wall clock when they began).

The bytes are written straight to the connections (no message object, no
serialization): the stamp is taken just before the write, so the latency the
subscriber sees is transport plus whatever sits in between, not this process's costs.
"""

from __future__ import annotations

import sys
import time

import nodeio
import rospy
import wire


def wait_for_subscriber(pub: rospy.Publisher, timeout: float = 60.0) -> None:
    deadline = time.monotonic() + timeout
    while pub.get_num_connections() == 0:
        if time.monotonic() > deadline:
            nodeio.say("error", "no subscriber connected")
            sys.exit(1)
        time.sleep(0.0002)


def write(pub: rospy.Publisher, packet: bytearray) -> None:
    for conn in pub.impl.connections:  # rospy replaces this list on change: iterating is safe
        try:
            conn.write_data(packet)
        except Exception:  # a subscriber went away: the bench counts loss downstream
            pass


def main() -> None:
    topic, kind = sys.argv[1], sys.argv[2]
    rate, rate_count, flat_count = float(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5])
    nodeio.start("bench_pub")
    pub = rospy.Publisher(topic, wire.message_class(kind), queue_size=None)
    packet = wire.template(kind)
    wait_for_subscriber(pub)

    period_ns = int(1e9 / rate)
    next_ns = time.monotonic_ns()
    for index in range(rate_count):
        now = time.monotonic_ns()
        if next_ns > now:
            time.sleep((next_ns - now) / 1e9)
        elif now - next_ns > 10 * period_ns:  # fell far behind (preempted): no catch-up burst
            next_ns = now
        next_ns += period_ns
        wire.stamp(packet, index, time.time_ns())
        write(pub, packet)
    nodeio.say("rate-done")

    if sys.stdin.readline().strip() != "go":
        return
    began, began_ns = time.monotonic(), time.time_ns()
    for index in range(rate_count, rate_count + flat_count):
        wire.stamp(packet, index, time.time_ns())
        write(pub, packet)
    nodeio.say("flat-done", f"{time.monotonic() - began:.6f}", began_ns)
    nodeio.serve()


if __name__ == "__main__":
    main()
