"""A guard's rules over what the robot senses, on either ROS, with real processes: a laser and a bumper published by
the test, a plain subscriber as the motors; the rules limit, stop and let only backing off pass, fail closed on an
input never heard or gone stale, and stop the last command when an obstacle appears with no new command."""

from __future__ import annotations

import json
import time

import pytest
from geometry_msgs.msg import Twist
from helpers import run_exported, stop_exported
from sensing import Sensors, approach, xs
from sensing import drive as sensing_drive
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Bool, String
from support import wait_for

from ipyros import rule
from ipyros.core import errors
from ipyros.dsl import engine_of

NEAR = rule("min(/ruled/scan.ranges) < 0.5", limit={"linear.x": (-0.2, 0.2)})
BUMPER = rule("/ruled/bumper.data", only="linear.x <= 0")


def test_rules_limit_near_an_obstacle_let_only_backing_off_past_the_bumper_and_stop_on_what_is_stale(
        make_node, peer, notices):
    motors = peer("listen_twist.py", "/ruled/cmd_vel", "--name=ruled_motors")
    motors.wait_line("ready")
    sensing = make_node("ruled_sensors")
    sensing.new.publish("/ruled/scan", msgType=LaserScan)
    sensing.new.publish("/ruled/bumper", msgType=Bool)
    sensing.create()
    sensors = Sensors(sensing, "/ruled/scan", "/ruled/bumper")
    verdicts: list[dict] = []  # what the guard publishes on ~guard_state, read back as a recording would
    make_node("ruled_verdicts").new.subscribe("/ruled/guard_state", msgType=String,
                                              handler=lambda m: verdicts.append(json.loads(m.data))).create()
    nd = make_node("ruled")
    nd.new.publish("/ruled/cmd_vel", msgType=Twist)
    nd.guard("/ruled/cmd_vel", limits={"linear.x": (-1.0, 1.0)}, rules=[NEAR, BUMPER], stale={"/ruled/scan": 0.5})
    nd.create()

    def drive(x: float, expect: float, what: str) -> None:
        sensing_drive(nd, "/ruled/cmd_vel", motors, x, expect, what)

    try:
        approach(drive, sensors)
        assert "limit linear.x -0.2..0.2 (in force)" in engine_of(nd).status().guards[0].rules[0]
        sensors.ranges = [2.0, 3.0]
        drive(0.4, 0.4, "the command as it came once the obstacle is gone")
        # An obstacle, and no new command: the last one, 0.4, would now be limited. The stop goes out as the scan
        # comes, not at the session watch's next look: with the watch's judging held back, it still comes.
        guard = engine_of(nd).guards.live["/ruled/cmd_vel"]
        guard.tend = lambda now: []  # the session's watch looks at it, and sees nothing to do
        try:
            appeared = time.monotonic()
            sensors.ranges = [0.3, 3.0]
            wait_for(lambda: 0.0 in xs(motors, appeared), timeout=10, what="the stop with no new command")
        finally:
            del guard.tend
        wait_for(lambda: "the last command would now be changed" in "".join(notices), timeout=10,
                 what="the line saying why")
        sensors.ranges, sensors.pressed = [2.0, 3.0], True
        drive(0.3, 0.0, "the stop message for a forward command while the bumper is pressed")
        drive(-0.2, -0.2, "backing off while the bumper is pressed")
        sensors.pressed = False
    finally:
        sensors.stop()
    gone = time.monotonic()
    wait_for(lambda: 0.0 in xs(motors, gone + 0.5), timeout=10, what="the stop once the laser went stale")
    wait_for(lambda: any("/ruled/scan stale" in n for n in notices), timeout=10, what="the stale laser told")
    status = engine_of(nd).status()
    assert status.guards[0].state.startswith("stopping: /ruled/scan stale"), status.guards[0].state
    assert status.guards[0].rules == ("1. when min(/ruled/scan.ranges) < 0.5: limit linear.x -0.2..0.2",
                                      "2. when /ruled/bumper.data: only linear.x <= 0")
    assert "2. when /ruled/bumper.data: only linear.x <= 0" in str(status)
    nd.write("/ruled/cmd_vel", Twist(linear=_vector(0.4)))
    time.sleep(0.5)
    assert 0.4 not in xs(motors, gone + 0.5), "nothing but the stop message while the laser is stale"
    # each verdict said at the prompt is a value on ~guard_state too: what it did, why, when
    kinds = [(v["acting"], v["why"]) for v in verdicts]
    assert {v["output"] for v in verdicts} == {"/ruled/cmd_vel"} and [v["stamp"] for v in verdicts] == \
        sorted(v["stamp"] for v in verdicts), verdicts
    # (the gate's report of each kind once an episode, clamped included, is tests/unit/core/test_guard.py's)
    assert ("stopped by a rule", "/ruled/scan not heard yet") in kinds, "\n".join(map(str, kinds))
    assert all(a != b for a, b in zip(kinds, kinds[1:])), f"a verdict published twice in a row: {kinds}"
    assert any(acting == "passed" for acting, _ in kinds) and \
        any(acting == "stopped by a rule" and "/ruled/scan stale" in why for acting, why in kinds), kinds


def _vector(x: float):
    from geometry_msgs.msg import Vector3

    return Vector3(x=x)


@pytest.mark.parametrize("rules, said", [
    ([rule("/ruled2/scan.nope < 1", stop=True)], "has no field 'nope'"),
    ([rule("true", limit={"linear.x": (0.1, 0.3)})], "outside rule 1's limit 0.1..0.3"),
    (["min(/ruled2/scan.ranges) < 1"], "is not a rule; make each with rule(condition, ...)"),
    ([rule("/ruled2/cmd_vel.linear.x > 1", stop=True)], "reads the guarded output itself"),
    ([rule("min(/ruled2/scan.ranges) <", stop=True)], "does not parse at its end"),
])
def test_a_rule_given_wrong_is_one_line_and_leaves_the_guard_as_it_was(make_node, rules, said):
    make_node("ruled2_laser").new.publish("/ruled2/scan", msgType=LaserScan).create()
    nd = make_node("ruled2")
    nd.new.publish("/ruled2/cmd_vel", msgType=Twist)
    with pytest.raises(errors.DeclarationError) as error:
        nd.guard("/ruled2/cmd_vel", rules=rules)
    assert said in str(error.value) and "\n" not in str(error.value)
    assert nd.model().guards == []


def test_a_guard_with_rules_is_kept_by_save_and_refused_by_an_export_that_cannot_read_its_inputs(make_node, tmp_path):
    nd = make_node("ruled3")
    nd.new.publish("/ruled3/cmd_vel", msgType=Twist)
    nd.guard("/ruled3/cmd_vel", rules=[rule("/ruled3/bumper.data", only="linear.x <= 0")], stale={"/ruled3/scan": 0.3})
    saved = nd.save(tmp_path / "ruled3.py").read_text()
    assert "rules=[{'condition': '/ruled3/bumper.data', 'only': 'linear.x <= 0'}]" in saved, saved
    assert "stale={'/ruled3/scan': 0.3}" in saved
    with pytest.raises(errors.IpyrosError, match=r"read /ruled3/bumper, and nothing publishes it now|C\+\+ export is "
                                                 "made for ROS 1"):  # ROS 1 compiles rules in; ROS 2 has no C++
        nd.export(tmp_path / "ruled3_pkg", language="cpp")
    with pytest.raises(errors.IpyrosError, match="read /ruled3/bumper, and nothing publishes it now"):
        nd.export(tmp_path / "ruled3_export.py")  # its input's type: the live graph's, and nothing shows it
    assert not (tmp_path / "ruled3_pkg").exists() and not (tmp_path / "ruled3_export.py").exists()


ruled_export = None


def forward_ruled_export(msg):
    """The handler of the exported node: what comes in goes out, through the guard and its rules."""
    ruled_export.write("/ruled4/cmd_vel", msg)


def test_an_exported_node_enforces_its_guards_rules_without_ipyros(make_node, peer, tmp_path):
    """The script, run with no ipyros to import: the stop while the laser was never heard, the limit near an
    obstacle, the stop when one appears with no new command, only backing off while the bumper is pressed, the stop
    once the laser is stale; each said once on its output."""
    global ruled_export
    motors = peer("listen_twist.py", "/ruled4/cmd_vel", "--name=ruled4_motors")
    motors.wait_line("ready")
    sensing = make_node("ruled4_sensors")
    sensing.new.publish("/ruled4/scan", msgType=LaserScan).publish("/ruled4/bumper", msgType=Bool)
    sensing.new.publish("/ruled4/in", msgType=Twist)
    sensing.create()
    sensors = Sensors(sensing, "/ruled4/scan", "/ruled4/bumper")
    nd = ruled_export = make_node("ruled4")  # declared, exported, never run in the session
    nd.new.publish("/ruled4/cmd_vel", msgType=Twist).subscribe("/ruled4/in", handler=forward_ruled_export,
                                                               msgType=Twist)
    nd.guard("/ruled4/cmd_vel", limits={"linear.x": (-1.0, 1.0)}, stale={"/ruled4/scan": 0.5},
             rules=[rule("min(/ruled4/scan.ranges) < 0.5", limit={"linear.x": (-0.2, 0.2)}),
                    rule("/ruled4/bumper.data", only="linear.x <= 0")])
    script = nd.export(tmp_path / "ruled_node.py")
    assert "class Rules:" in script.read_text() and "import ipyros" not in script.read_text()
    package = nd.export(tmp_path / "ruled4_pkg")  # the package's node: the same script, as a module or in scripts/
    ruled = [f for f in package.rglob("ruled4*") if f.is_file() and "class Rules:" in f.read_text()]
    assert len(ruled) == 1, sorted(map(str, package.rglob("*")))
    compile(ruled[0].read_text(), str(ruled[0]), "exec")
    node, said = run_exported(script, tmp_path)

    def drive(x: float, expect: float, what: str) -> None:
        sensing_drive(sensing, "/ruled4/in", motors, x, expect, what)

    try:
        try:
            approach(drive, sensors)
            sensors.ranges = [2.0, 3.0]
            drive(0.4, 0.4, "the command as it came once the obstacle is gone")
            appeared = time.monotonic()
            sensors.ranges = [0.3, 3.0]  # and no new command: the last, 0.4, would now be limited
            wait_for(lambda: 0.0 in xs(motors, appeared), timeout=10, what="the stop with no new command")
            sensors.ranges, sensors.pressed = [2.0, 3.0], True
            drive(0.3, 0.0, "the stop message for a forward command while the bumper is pressed")
            drive(-0.2, -0.2, "backing off while the bumper is pressed")
        finally:
            sensors.stop()
        gone = time.monotonic()
        wait_for(lambda: 0.0 in xs(motors, gone + 0.5), timeout=10, what="the stop once the laser went stale")
        wait_for(lambda: "/ruled4/scan stale" in said.read_text(), timeout=10, what="the stale laser said")
        lines = said.read_text()
        assert "guard /ruled4/cmd_vel: /ruled4/scan not heard yet: the stop message goes out until its rules let a " \
            "command pass" in lines and "guard /ruled4/cmd_vel: its rules let commands pass again" in lines, lines
    finally:
        stop_exported(node)
