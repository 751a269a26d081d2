"""What a guard's rules read, published by a test, and commands driven until the motors show what was expected:
shared by the tests of a guard kept in the session (tests/both/test_guard_rules.py) and of one placed on a machine
(tests/both/test_placed_rules.py)."""

from __future__ import annotations

import threading
import time
from typing import Any

from geometry_msgs.msg import Twist, Vector3
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Bool
from support import wait_for

__all__ = ["Sensors", "approach", "drive", "xs"]


def xs(listener: Any, after: float = 0.0) -> list[float]:
    """linear.x of each command the motors heard after ``after`` (their clock: this machine's monotonic clock)."""
    heard = [line.split()[1:] for line in list(listener.lines) if line.startswith("twist ")]
    return [float(x) for x, _, _, t in heard if float(t) > after]


class Sensors:
    """A laser on ``scan`` (and a bumper on ``bumper``, if given), published at 20 Hz by a thread until stopped
    (``ranges``, ``pressed`` as set), through ``node`` (a DSL node that declared them)."""

    def __init__(self, node: Any, scan: str, bumper: str = "") -> None:
        self.node, self.scan, self.bumper = node, scan, bumper
        self.ranges, self.pressed = [2.0, 3.0], False
        self.running = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        while self.running.is_set():
            scan = LaserScan()
            scan.ranges = list(self.ranges)
            self.node.write(self.scan, scan)
            if self.bumper:
                self.node.write(self.bumper, Bool(data=self.pressed))
            time.sleep(0.05)

    def start(self) -> None:
        self.running.set()
        self.thread.start()

    def stop(self) -> None:
        if self.running.is_set():
            self.running.clear()
            self.thread.join(5)


def drive(node: Any, topic: str, motors: Any, x: float, expect: float, what: str) -> None:
    """Write linear.x = ``x`` on ``topic`` until the motors hear ``expect``; then, for a moment, nothing else."""
    since = time.monotonic()
    wait_for(lambda: node.write(topic, Twist(linear=Vector3(x=x))) or expect in xs(motors, since),
             timeout=30, interval=0.1, what=what)
    time.sleep(0.3)
    assert set(xs(motors, time.monotonic() - 0.2)) <= {expect}, f"{what}: {xs(motors, since)[-10:]}"


def approach(drive: Any, sensors: Sensors) -> None:
    """The first legs under a rule limiting linear.x to 0.2 near an obstacle (under 0.5 m) and a laser required:
    the stop message while the laser was never heard, a command as it came with nothing near, then limited near an
    obstacle. ``drive(x, expect, what)`` writes until the motors hear ``expect``."""
    drive(0.4, 0.0, "the stop message while the laser was never heard")
    sensors.start()
    drive(0.4, 0.4, "a command passing as it came, nothing near")
    sensors.ranges = [0.3, 3.0]
    drive(0.4, 0.2, "the command limited near an obstacle")
