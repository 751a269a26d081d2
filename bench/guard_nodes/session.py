"""The session of the guard bench: an ipyros node whose output is guarded, driven by the bench over stdin.

    python session.py TOPIC TIMEOUT

The same script on either ROS (ipyros picks it; the bench's venv has one). The node publishes
``geometry_msgs/TwistStamped`` on TOPIC through a guard: ``twist.linear.x`` within +-0.5,
``twist.angular.z`` within +-1, stop on TIMEOUT seconds of silence at 20 Hz, half a second's grace.
It publishes the same on TOPIC_ruled through a guard with one rule over what the robot senses: the stop while
``/bench/range`` (``std_msgs/Float32``, published here at 20 Hz, 5 m until an obstacle) is under 0.5 m.
Says ``ready SENTINEL_PID`` once the guard's process publishes, then answers a line at a time:

``drive N HZ [BUSY]``  N commands (linear.x 0.3, stamped with the wall clock) at HZ, then ``silent STAMP``
                       (the last one's); with BUSY, then BUSY seconds of pure Python holding the GIL (a long
                       cell at the prompt), then ``spun``
``hostile N``          N messages of hostile values (NaN, infinities, huge, -0.0, the wrong sign, just
                       outside) written flat out, then ``wrote N SECONDS``
``obstacle``           one command on TOPIC_ruled, then, a moment later and with no command after it, the range
                       0.2 m: ``near STAMP`` (the wall clock as it was published)
``clear``              the range 5 m again, a moment to let the rule go: ``clear``
"""

from __future__ import annotations

import math
import random
import sys
import threading
import time

from geometry_msgs.msg import TwistStamped
from std_msgs.msg import Float32

from ipyros import rule
from ipyros.dsl import engine_of, rosNode

RANGE = "/bench/range"

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


class Laser:
    """The range the rule reads, published at 20 Hz from a thread; :meth:`set` publishes a new one at once."""

    def __init__(self) -> None:
        self.node = rosNode("bench_laser").new.publish(RANGE, type=Float32).create()
        self.lock, self.value, self.done = threading.Lock(), 5.0, threading.Event()
        threading.Thread(target=self._beat, daemon=True).start()

    def set(self, value: float) -> float:
        with self.lock:
            self.value, now = value, time.time()
            self.node.write(RANGE, Float32(data=value))
        return now

    def _beat(self) -> None:
        while not self.done.wait(0.05):
            with self.lock:
                self.node.write(RANGE, Float32(data=self.value))


def obstacle(node: rosNode, laser: Laser, topic: str) -> None:
    msg = TwistStamped()
    msg.twist.linear.x = 0.3
    stamp(msg, time.time())
    node.write(topic, msg)
    time.sleep(0.3)  # the command is at the robot; none follows it
    say("near", repr(laser.set(0.2)))


def main() -> None:
    topic, timeout = sys.argv[1], float(sys.argv[2])
    ruled = topic + "_ruled"
    laser = Laser()
    node = rosNode("bench_guarded")
    node.new.publish(topic, type=TwistStamped).publish(ruled, type=TwistStamped)
    node.guard(topic, limits={"twist.linear.x": (-0.5, 0.5), "twist.angular.z": (-1.0, 1.0)}, timeout=timeout,
               repeat=20.0, grace=0.5)
    node.guard(ruled, rules=[rule(f"{RANGE}.data < 0.5", stop=True)], repeat=20.0, grace=0.5)
    node.create()
    engine = engine_of(node)
    while not all(guard.reach for guard in engine.status().guards):  # its processes have found the robot
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
            elif words[0] == "obstacle":
                obstacle(node, laser, ruled)
            elif words[0] == "clear":
                laser.set(5.0)
                time.sleep(0.3)
                say("clear")
            else:
                say("error", f"unknown command {words[0]!r}")
    finally:
        laser.done.set()
        node.shutdown()
        laser.node.shutdown()


if __name__ == "__main__":
    main()
