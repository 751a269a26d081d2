"""A guard placed on a machine with rules over what the robot senses, on either ROS: its keeper reads the sensors on
the robot and judges there, so the robot keeps to them on its own clock. A laser published by the test, a plain
subscriber as the motors, the keeper a process of its own: the stop while the laser was never heard, the limit near
an obstacle, the stop with no new command when one appears, and the stop once the laser goes stale."""

from __future__ import annotations

import json
import time

import pytest
from geometry_msgs.msg import Twist
from keepers import Keepers
from sensing import Sensors, drive, xs
from sensor_msgs.msg import LaserScan
from std_msgs.msg import String
from support import wait_for

from ipyros import rule
from ipyros.dsl import engine_of

NEAR = rule("min(/pr/scan.ranges) < 0.5", limit={"linear.x": (-0.2, 0.2)})


@pytest.fixture
def keeper(session):
    """Start the keeper ``rulebot``; after the test, ended with all it started."""
    keepers = Keepers(session.backend.name)
    yield lambda: keepers.start("rulebot")
    keepers.end()


def test_a_placed_guard_reads_the_robots_sensors_on_the_robot_and_keeps_to_its_rules_there(make_node, peer, keeper):
    machine = keeper()
    motors = peer("listen_twist.py", "/pr/cmd_vel", "--name=pr_motors")
    motors.wait_line("ready")
    sensing = make_node("pr_sensors").new.publish("/pr/scan", msgType=LaserScan).create()
    sensors = Sensors(sensing, "/pr/scan")
    verdicts: list[dict] = []  # what the guard publishes on ~guard_state, as its keeper reports it
    make_node("pr_verdicts").new.subscribe("/pr/guard_state", msgType=String,
                                           handler=lambda m: verdicts.append(json.loads(m.data))).create()
    nd = make_node("pr")
    nd.new.publish("/pr/cmd_vel", msgType=Twist)
    nd.guard("/pr/cmd_vel", limits={"linear.x": (-1.0, 1.0)}, rules=[NEAR], stale={"/pr/scan": 0.5},
             machine="rulebot")
    nd.create()
    try:
        drive(nd, "/pr/cmd_vel", motors, 0.4, 0.0, "the stop message while the laser was never heard on the robot")
        sensors.start()
        drive(nd, "/pr/cmd_vel", motors, 0.4, 0.4, "a command passing as it came, nothing near")
        appeared = time.monotonic()
        sensors.ranges = [0.3, 3.0]  # an obstacle, and no new command: the last one, 0.4, would now be limited
        wait_for(lambda: 0.0 in xs(motors, appeared), timeout=10, what="the stop with no new command")
        machine.wait_line("guard /pr/cmd_vel: the last command would now be changed (linear.x 0.4 -> 0.2)", timeout=10)
        drive(nd, "/pr/cmd_vel", motors, 0.4, 0.2, "the command limited near the obstacle, on the robot")
        (state,) = engine_of(nd).status().guards
        assert state.rules == ("1. when min(/pr/scan.ranges) < 0.5: limit linear.x -0.2..0.2 (in force)",), state
    finally:
        sensors.stop()
    gone = time.monotonic()
    wait_for(lambda: 0.0 in xs(motors, gone + 0.5), timeout=10, what="the stop once the laser went stale")
    wait_for(lambda: engine_of(nd).status().guards[0].state.startswith("stopping: /pr/scan stale"), timeout=10,
             what="the stale laser in the keeper's report")
    machine.wait_line("guard /pr/cmd_vel: /pr/scan stale", timeout=10)
    kinds = [(v["acting"], v["why"]) for v in verdicts]
    assert ("stopped by a rule", "/pr/scan not heard yet") in kinds and \
        any(acting == "stopped by a rule" and why.startswith("/pr/scan stale") for acting, why in kinds), kinds
