"""The session of the guard bench: an ipyros node whose output is guarded, driven by the bench over stdin.

    python session.py TOPIC TIMEOUT

The same script on either ROS (ipyros picks it; the bench's venv has one). The node publishes
``geometry_msgs/TwistStamped`` on TOPIC through a guard: ``twist.linear.x`` within +-0.5,
``twist.angular.z`` within +-1, stop on TIMEOUT seconds of silence at 20 Hz, half a second's grace.
Says ``ready SENTINEL_PID`` once the guard's process publishes, then answers a line at a time:

``drive N HZ [BUSY]``  N commands (linear.x 0.3, stamped with the wall clock) at HZ, then ``silent STAMP``
                       (the last one's); with BUSY, then BUSY seconds of pure Python holding the GIL (a long
                       cell at the prompt), then ``spun``
``hostile N``          N messages of hostile values (NaN, infinities, huge, -0.0, the wrong sign, just
                       outside) written flat out, then ``wrote N SECONDS``
"""

from __future__ import annotations

import math
import random
import sys
import time

from geometry_msgs.msg import TwistStamped

from ipyros.dsl import engine_of, rosNode

HOSTILE = (math.nan, -math.nan, math.inf, -math.inf, 1e308, -1e308, 2.0 ** 63, -0.0, 0.0, 0.3, -0.3, 0.5, -0.5,
           0.5000001, -0.5000001, 1.0000001, -5.0, 5.0, 5e-324, -1e-300)


def say(*words: object) -> None:
    sys.stdout.write(" ".join(str(w) for w in words) + "\n")
    sys.stdout.flush()


def stamp(msg: TwistStamped, t: float) -> None:
    """``header.stamp`` = ``t`` (s), in either ROS's field names."""
    s = msg.header.stamp
    sec, nsec = int(t), int((t - int(t)) * 1e9)
    if hasattr(s, "secs"):
        s.secs, s.nsecs = sec, nsec
    else:
        s.sec, s.nanosec = sec, nsec


def drive(node: rosNode, topic: str, count: int, hz: float, busy: float) -> None:
    period, last = 1.0 / hz, 0.0
    start = time.monotonic()
    for i in range(count):
        time.sleep(max(0.0, start + i * period - time.monotonic()))
        msg = TwistStamped()
        msg.twist.linear.x = 0.3
        last = time.time()
        stamp(msg, last)
        node.write(topic, msg)
    say("silent", repr(last))
    if busy:
        end, total = time.monotonic() + busy, 0
        while time.monotonic() < end:
            total += sum(range(2000))  # Python bytecode: the GIL held but for the interpreter's switches
        say("spun")


def hostile(node: rosNode, topic: str, count: int) -> None:
    pick = random.Random(7).choice
    messages = []
    for i in range(count):
        msg = TwistStamped()
        msg.header.frame_id = str(i)
        t = msg.twist
        t.linear.x, t.linear.y, t.linear.z = pick(HOSTILE), pick(HOSTILE), pick(HOSTILE)
        t.angular.x, t.angular.y, t.angular.z = pick(HOSTILE), pick(HOSTILE), pick(HOSTILE)
        messages.append(msg)
    began = time.monotonic()
    for msg in messages:
        node.write(topic, msg)
    say("wrote", count, repr(time.monotonic() - began))


def main() -> None:
    topic, timeout = sys.argv[1], float(sys.argv[2])
    node = rosNode("bench_guarded")
    node.new.publish(topic, type=TwistStamped)
    node.guard(topic, limits={"twist.linear.x": (-0.5, 0.5), "twist.angular.z": (-1.0, 1.0)}, timeout=timeout,
               repeat=20.0, grace=0.5)
    node.create()
    engine = engine_of(node)
    while not engine.status().guards[0].reach:  # its process has found the robot: its stop messages reach it
        time.sleep(0.05)
    say("ready", engine.guards.live[node.resolve(topic)].sentinel.pid)
    try:
        for line in sys.stdin:
            words = line.split()
            if not words:
                continue
            if words[0] == "quit":
                break
            if words[0] == "drive":
                drive(node, topic, int(words[1]), float(words[2]), float(words[3]) if len(words) > 3 else 0.0)
            elif words[0] == "hostile":
                hostile(node, topic, int(words[1]))
            else:
                say("error", f"unknown command {words[0]!r}")
    finally:
        node.shutdown()


if __name__ == "__main__":
    main()
