"""Guard benchmark: how soon the stop message follows silence, and that hostile values never reach the robot.

    python -m bench.guard            # 100 trips in each state, 100,000 hostile messages (about 4 minutes)
    python -m bench.guard --quick    # 20 trips, 20,000 messages

Run with the venv of either ROS (``bash run.sh bench`` runs it in both). Two processes of the
bench's own, on a rosmaster of its own (ROS 1) or a DDS domain of its own (ROS 2):

* the *session* (``bench/guard_nodes/session.py``): an ipyros node whose ``TwistStamped`` output has
  a guard (limits on ``linear.x`` and ``angular.z``, stop on ``TIMEOUT`` s of silence); the guard's
  own process (its sentinel) is the session's child, as at the prompt;
* the *robot* (``bench/guard_nodes/robot.py``): a plain rospy or rclpy subscriber of that output,
  which notes when each message came and whether it breaks the rules.

**Silence to the stop message**: the session drives (20 commands at 50 Hz, each stamped with the
wall clock as it is written), then falls silent; the figure is the time from the last command's
stamp to the first stop message at the robot, over ``--trips`` trips, p50 and p99, in three states
of the session: *idle* (at the prompt, waiting), *busy* (pure Python holding the GIL for a second,
a long cell) and *frozen* (SIGSTOP, as Ctrl-Z or a debugger leaves it; SIGCONT once the stop came).
Targets (issue 40): p99 within the timeout + 20 ms on ROS 1, + 50 ms on ROS 2.

**An obstacle, no command coming**: the session's second output has a guard with one rule over what the robot
senses (the stop while a range it publishes at 20 Hz is under 0.5 m); one command passes, then, with none after it,
the range drops to 0.2 m; the figure is the time from that range's publication to the first stop message at a
second robot, over ``--trips`` obstacles. Target (issue 49): p99 within the guard's repeat period (50 ms) + 20 ms
on ROS 1, + 50 ms on ROS 2.

**The rules' cost**: a ``Twist`` checked by the gate against three rules over a 720-ray scan (the nearest
obstacle ahead, a slow-down band, a battery) beside the same gate with none, in this process, with no ROS in
between; the figure is the time a check takes more with the rules, per command. Target (issue 49): at most 30 µs.

**Hostile commands under rules**: ``RULED`` commands of the same hostile values through a gate with four rules (a
stop and a limit over a laser's nearest ray, only backing off while a bumper is pressed, half speed on a low battery)
whose inputs change underneath between commands: rays of NaN, infinities or none at all, a stale or never-heard
input, one of the wrong type. An oracle written from what the rules promise checks each message that leaves
(:func:`hostile_rules`); the target is 0 outside them. In this process, on this ROS's messages, no ROS in between.

**Hostile values**: the session writes ``--hostile`` messages flat out whose six numbers are drawn
from NaN, infinities, +-1e308, 2**63, -0.0, denormals, just outside the limits and the wrong sign;
the robot counts what it got and what broke the rules: the target is 0. The rate the guarded
writes went out at is shown.

The guard's cost per message against the unguarded relay is path (g) of the relay benches
(``bench/relay.py``, ``bench/relay_ros2.py``), beside path (c) in the same run.
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import os
import random
import signal
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Optional

from bench.figures import Figure, keep, machine, table, target_lines
from bench.relay import BenchError, Child, Master, stop_cleanly_on_sigterm, wait_until

HERE = Path(__file__).resolve().parent
NODES = HERE / "guard_nodes"
RESULTS = HERE / "results"
TOPIC = "/bench/guarded_cmd"
TIMEOUT = 0.25  # s of silence before the stop message
DRIVE = (20, 50.0)  # commands a trip, and their rate (Hz)
BUSY = 1.0  # s the session computes after its last command, in the busy state
STATES = ("idle", "busy", "frozen")
#: What each ROS's p99 may add to the timeout (issue 40), or to the repeat period for an obstacle (issue 49), ms.
MARGIN_MS = {"ROS 1": 20.0, "ROS 2": 50.0}
REPEAT = 0.05  # s between the guards' stop messages (20 Hz)


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(len(ordered) * q))]


def gone(pid: int, timeout: float) -> bool:
    """Whether process ``pid`` (not a child of ours: the sentinel is the session's) has exited within ``timeout``."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return True
        time.sleep(0.05)
    return False


def settled(count, quiet: float, slack: int, timeout: float, what: str) -> None:
    """Wait until ``count()`` has grown by at most ``slack`` in ``quiet`` seconds: what was sent has arrived, and
    only the guard's stop messages, at its repeat rate, still come."""
    last, since, deadline = count(), time.monotonic(), time.monotonic() + timeout
    while time.monotonic() - since < quiet:
        if time.monotonic() > deadline:
            raise BenchError(f"timed out after {timeout:.0f}s waiting for {what} to settle")
        time.sleep(0.05)
        now = count()
        if now - last > slack:
            last, since = now, time.monotonic()


def trips(session: Child, robot: Child, state: str, count: int) -> list[float]:
    """``count`` trips of the session in ``state``: the ms from the last command's stamp to the first stop."""
    pid = session.proc.pid
    delays = []
    for _ in range(count):
        busy = f" {BUSY}" if state == "busy" else ""
        session.send(f"drive {DRIVE[0]} {DRIVE[1]}{busy}")
        session.expect("silent", 30)
        if state == "frozen":
            os.kill(pid, signal.SIGSTOP)
        try:
            answer = wait_until(lambda: (lambda a: a if a != "none" else None)(robot.ask("trip")), 10 + TIMEOUT,
                                f"the stop message after silence ({state})", 0.01)
        finally:
            if state == "frozen":
                os.kill(pid, signal.SIGCONT)
        if state == "busy":
            session.expect("spun", 30)
        last, stop = (float(word) for word in answer.split())
        delays.append((stop - last) * 1000.0)
    return delays


#: The rules' cost: commands checked each way, and the most a check may take more with the rules (µs).
CHECKS, RULES_MOST_US = 20000, 30.0


def rules_cost(checks: int = CHECKS) -> tuple[float, float]:
    """µs a check of a Twist takes through a gate with three rules over a 720-ray scan, and with none."""
    import math

    from geometry_msgs.msg import Twist
    from sensor_msgs.msg import BatteryState, LaserScan

    from ipyros.core.guard import Gate
    from ipyros.core.rules import RuleSet, rule

    scan = LaserScan()
    scan.ranges = [2.0 + math.sin(i / 10) for i in range(720)]
    battery = BatteryState()
    battery.percentage = 0.8
    heard = {"/scan": (scan, 0.0), "/battery": (battery, 0.0)}
    rules = RuleSet([rule("min(/scan.ranges) < 0.5", stop=True),
                     rule("min(/scan.ranges) < 1.5", limit={"linear.x": (-0.3, 0.3)}),
                     rule("/battery.percentage < 0.1", stop=True)], Twist, "/cmd_vel", {"/scan": 1.0}, "bench")

    def timed(given: Optional[RuleSet]) -> float:
        gate = Gate("/cmd_vel", Twist, {"linear.x": (-1.0, 1.0)}, {}, "clamp", Twist, lambda: False, lambda: None,
                    lambda text: None, clock=lambda: 0.5, rules=given, heard=lambda: heard)
        command = Twist()
        command.linear.x = 0.2
        began = time.perf_counter()
        for _ in range(checks):
            gate.check(command)
        return (time.perf_counter() - began) / checks * 1e6

    timed(rules), timed(None)  # warm: the checkers compiled once
    return statistics.median(timed(rules) for _ in range(3)), statistics.median(timed(None) for _ in range(3))


#: Hostile commands through a gate with rules whose inputs change underneath (in this process: a few seconds).
RULED = 100_000
#: Values a hostile command's numbers are drawn from; a laser's rays, a battery's level.
HOSTILE = (math.nan, math.inf, -math.inf, 1e308, -1e308, -0.0, 0.0, 0.29, 0.3, 0.31, 1.0, 1.0000001, -1.0000001,
           3.0, -3.0, 0.4, -0.4, -0.2, 0.2)
RAYS = (math.nan, math.inf, -math.inf, 0.29, 0.3, 0.31, 0.99, 1.0, *[2.0, 5.0] * 8)
LEVELS = (math.nan, math.inf, 0.1, 0.19, 0.2, 0.21, 0.9, 0.9, 0.9, 0.9)


def hostile_rules(count: int, twist: type, vector3: type, scan: tuple[type, str], bumper: tuple[type, str],
                  battery: tuple[type, str], wrong: type, seed: int = 49) -> dict[str, int]:
    """``count`` hostile commands through a gate with four rules whose inputs change underneath, at random, between
    commands: a laser (``scan``: its class and array field; NaN, infinities, no ray at all), a bumper (a flag), a
    battery (a level), each also gone stale, never heard, or of the ``wrong`` type; the clock goes on. Each message
    that leaves is checked by an oracle of its own, written from what the rules promise, not from how they are
    judged: finite; within the guard's limits; the stop message when an input is unknown, stale, of the wrong type,
    or a laser with no valid ray or one under 0.3 m; linear.x within 0.3 under 1 m; never forward while the bumper
    is pressed. What it returns: how many broke them (``outside``), and how many were stopped, changed or passed."""
    from ipyros.core.guard import Gate
    from ipyros.core.rules import RuleSet, rule

    (scan_cls, ranges), (bumper_cls, pressed), (battery_cls, level) = scan, bumper, battery
    rules = RuleSet([rule(f"min(/scan.{ranges}) < 0.3", stop=True),
                     rule(f"min(/scan.{ranges}) < 1.0", limit={"linear.x": (-0.3, 0.3)}),
                     rule(f"/bumper.{pressed}", only="linear.x <= 0"),
                     rule(f"/battery.{level} < 0.2", scale=0.5)], twist, "/cmd_vel",
                    {"/scan": 0.5, "/bumper": 0.5}, "bench")
    now = [100.0]
    heard: dict[str, tuple[object, float]] = {}
    gate = Gate("/cmd_vel", twist, {"linear.x": (-1.0, 1.0), "angular.z": (-2.0, 2.0)}, {}, "clamp", twist,
                lambda: False, lambda: None, lambda text: None, clock=lambda: now[0], rules=rules, heard=lambda: heard)
    rng = random.Random(seed)

    def message(cls: type, field: str, value: object) -> object:
        msg = cls()
        setattr(msg, field, value)
        return msg

    makers = {"/scan": lambda: message(scan_cls, ranges, [rng.choice(RAYS) for _ in range(rng.choice((0, 1, 2, 3, 3, 3, 3, 3)))]),
              "/bumper": lambda: message(bumper_cls, pressed, rng.random() < 0.3),
              "/battery": lambda: message(battery_cls, level, rng.choice(LEVELS))}
    tally = {"outside": 0, "stopped": 0, "changed": 0, "passed": 0}

    def fresh(topic: str, cls: type, stale: Optional[float]) -> object:
        """The input's last message, if it is of its type and fresh enough: what the rules may read."""
        msg, at = heard.get(topic, (None, 0.0))
        return msg if isinstance(msg, cls) and (stale is None or now[0] - at <= stale) else None

    for _ in range(count):
        now[0] += rng.random() * 0.05
        for topic, make in makers.items():
            roll = rng.random()
            if roll < 0.3:
                heard[topic] = (make(), now[0] - rng.random() * 0.3)
            elif roll < 0.32:
                heard[topic] = (make(), now[0] - 0.8)  # stale
            elif roll < 0.33:
                heard[topic] = (wrong(), now[0])
            elif roll < 0.34:
                heard.pop(topic, None)
        command = twist(linear=vector3(x=rng.choice(HOSTILE), y=rng.choice(HOSTILE)),
                        angular=vector3(z=rng.choice(HOSTILE)))
        sent = gate.check(command).send
        values = [sent.linear.x, sent.linear.y, sent.linear.z, sent.angular.x, sent.angular.y, sent.angular.z]
        stop = not any(values) and all(math.isfinite(v) for v in values)
        given = [command.linear.x, command.linear.y, command.angular.z]
        tally["stopped" if stop else "passed" if [values[0], values[1], values[5]] == given else "changed"] += 1
        if not all(math.isfinite(v) for v in values) or abs(values[0]) > 1.0 or abs(values[5]) > 2.0:
            tally["outside"] += 1
            continue

        laser, bump, power = (fresh("/scan", scan_cls, 0.5), fresh("/bumper", bumper_cls, 0.5),
                              fresh("/battery", battery_cls, None))
        rays = [r for r in getattr(laser, ranges, []) if not math.isnan(r)]
        if laser is None or bump is None or power is None or not rays or min(rays) < 0.3 or \
                math.isnan(getattr(power, level)):
            tally["outside"] += not stop
            continue
        if (min(rays) < 1.0 and abs(values[0]) > 0.3) or (getattr(bump, pressed) and values[0] > 0):
            tally["outside"] += 1
    return tally


def hostile_ros_rules(count: int) -> dict[str, int]:
    """:func:`hostile_rules` on this ROS's own messages: a Twist, a LaserScan, a Bool bumper, a BatteryState."""
    from geometry_msgs.msg import Twist, Vector3
    from sensor_msgs.msg import BatteryState, LaserScan
    from std_msgs.msg import Bool, String

    return hostile_rules(count, Twist, Vector3, (LaserScan, "ranges"), (Bool, "data"), (BatteryState, "percentage"),
                         String)


def obstacles(session: Child, robot: Child, count: int) -> list[float]:
    """``count`` obstacles with no command coming: the ms from the range's publication to the first stop."""
    delays = []
    for _ in range(count):
        session.send("obstacle")
        near = float(session.expect("near", 30))
        answer = wait_until(lambda: (lambda a: a if a != "none" else None)(robot.ask("trip")), 10,
                            "the stop message after an obstacle", 0.01)
        delays.append((float(answer.split()[1]) - near) * 1000.0)
        session.send("clear")
        session.expect("clear", 30)
    return delays


def run(ros: str, env: dict[str, str], workdir: Path, count: int, hostile: int) -> tuple[dict[str, list[float]], dict]:
    procs: list[Child] = []
    sentinel: Optional[int] = None
    try:
        robot = Child("robot", [sys.executable, str(NODES / "robot.py"), TOPIC], env, workdir)
        procs.append(robot)
        robot.expect("ready", 60)
        ruled = Child("robot_ruled", [sys.executable, str(NODES / "robot.py"), TOPIC + "_ruled", "bench_robot_ruled"], env, workdir)
        procs.append(ruled)
        ruled.expect("ready", 60)
        session = Child("session", [sys.executable, str(NODES / "session.py"), TOPIC, str(TIMEOUT)], env, workdir)
        procs.append(session)
        sentinel = int(session.expect("ready", 90))
        wait_until(lambda: int(robot.ask("publishers")) >= 2, 30, "the robot to hear the session and its guard", 0.05)
        delays = {}
        for state in STATES:
            trips(session, robot, state, 2)  # warm-up: the first connection, the first stop
            delays[state] = trips(session, robot, state, count)
            print(f"  {ros} {state:6}: silence to stop p50 {statistics.median(delays[state]):.1f} ms, "
                  f"p99 {percentile(delays[state], 0.99):.1f} ms (timeout {TIMEOUT * 1000:.0f} ms)", flush=True)
        wait_until(lambda: int(ruled.ask("publishers")) >= 2, 30, "the second robot to hear its output", 0.05)
        obstacles(session, ruled, 2)  # warm-up
        delays["obstacle"] = obstacles(session, ruled, count)
        print(f"  {ros} obstacle: to the stop p50 {statistics.median(delays['obstacle']):.1f} ms, "
              f"p99 {percentile(delays['obstacle'], 0.99):.1f} ms (repeat period {REPEAT * 1000:.0f} ms)", flush=True)
        before, _ = (int(w) for w in robot.ask("tally").split())
        session.send(f"hostile {hostile}")
        wrote, seconds = session.expect("wrote", 600).split()
        if ros == "ROS 1":
            wait_until(lambda: int(robot.ask("tally").split()[0]) - before >= hostile, 30, "the hostile messages", 0.1)
        else:  # ROS 2 keeps the last 1000: some may be overtaken, so wait until only the stop messages come
            settled(lambda: int(robot.ask("tally").split()[0]), 0.5, 10, 30, "the hostile messages")
        received, outside = (int(w) for w in robot.ask("tally").split())
        hostile_run = {"sent": int(wrote), "received": received - before, "outside": outside,
                       "per_s": int(wrote) / float(seconds)}
        print(f"  {ros} hostile: {hostile_run}", flush=True)
        return delays, hostile_run
    finally:
        for proc in reversed(procs):
            proc.stop()
        if sentinel is not None and not gone(sentinel, 15.0):  # it holds the stop for its grace, then ends
            os.kill(sentinel, signal.SIGKILL)
            print(f"bench: the guard's process {sentinel} outlived its grace (killed)", file=sys.stderr)


def figures(ros: str, delays: dict[str, list[float]], hostile_run: dict, cost: tuple[float, float],
            ruled: dict[str, int]) -> list[Figure]:
    most = TIMEOUT * 1000 + MARGIN_MS[ros]
    with_rules, without = cost
    out = [Figure(ros, "guard: a command checked against 3 rules over a 720-ray scan, more than with none",
                  with_rules - without, "µs", most=RULES_MOST_US,
                  note=f"{with_rules:.1f} µs with them, {without:.1f} µs without")]
    for state, values in delays.items():
        if state == "obstacle":
            out += [Figure(ros, f"guard: an obstacle to the stop message, no command coming, p50 of {len(values)}",
                           statistics.median(values), "ms"),
                    Figure(ros, f"guard: an obstacle to the stop message, no command coming, p99 of {len(values)}",
                           percentile(values, 0.99), "ms", most=REPEAT * 1000 + MARGIN_MS[ros],
                           note=f"repeat period {REPEAT * 1000:.0f} ms + {MARGIN_MS[ros]:.0f} ms")]
            continue
        out += [Figure(ros, f"guard: silence to the stop message, session {state}, p50 of {len(values)}",
                       statistics.median(values), "ms"),
                Figure(ros, f"guard: silence to the stop message, session {state}, p99 of {len(values)}",
                       percentile(values, 0.99), "ms", most=most,
                       note=f"timeout {TIMEOUT * 1000:.0f} ms + {MARGIN_MS[ros]:.0f} ms")]
    out += [Figure(ros, f"guard: hostile messages at the robot outside the rules, of {hostile_run['received']:,}",
                   hostile_run["outside"], "msgs", most=0),
            Figure(ros, "guard: hostile messages written through it, flat out", hostile_run["per_s"], "msg/s"),
            Figure(ros, f"guard: hostile commands outside 4 rules, their inputs changing underneath, of "
                        f"{sum(ruled.values()) - ruled['outside']:,}", ruled["outside"], "msgs", most=0,
                   note=f"{ruled['stopped']:,} stopped, {ruled['changed']:,} changed, {ruled['passed']:,} as they came")]
    return out


def main(argv: Optional[list[str]] = None) -> int:
    stop_cleanly_on_sigterm()
    parser = argparse.ArgumentParser(prog="python -m bench.guard", description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="20 trips a state, 20,000 hostile messages")
    parser.add_argument("--trips", type=int, default=None)
    parser.add_argument("--hostile", type=int, default=None)
    args, _ = parser.parse_known_args(argv)  # `bash run.sh bench` passes the other benches' options too
    count = args.trips or (20 if args.quick else 100)
    hostile = args.hostile or (20000 if args.quick else 100000)
    ros = "ROS 1" if importlib.util.find_spec("rospy") else "ROS 2"
    began = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="ipyros-bench-guard-") as tmp:
        workdir = Path(tmp)
        master = None
        try:
            if ros == "ROS 1":
                master = Master(workdir)
                env = dict(master.env)
            else:
                from bench.relay_ros2 import environment
                env = {**environment(), "IPYROS_ROS": "2", "ROS_HOME": tmp, "ROS_LOG_DIR": str(workdir / "log")}
            env["PYTHONPATH"] = os.pathsep.join(p for p in (str(HERE.parent), env.get("PYTHONPATH")) if p)
            delays, hostile_run = run(ros, env, workdir, count, hostile)
        except BenchError as error:
            print(f"bench: {error}", file=sys.stderr)
            return 1
        except KeyboardInterrupt:
            print("guard bench interrupted", file=sys.stderr)
            return 130
        finally:
            if master is not None:
                master.stop()
    cost = rules_cost()
    print(f"  {ros} rules: a check {cost[0]:.1f} µs with 3 rules over 720 rays, {cost[1]:.1f} µs without", flush=True)
    ruled = hostile_ros_rules(RULED)
    print(f"  {ros} hostile under rules, their inputs changing: {ruled}", flush=True)
    checks = figures(ros, delays, hostile_run, cost, ruled)
    text = (f"Machine: {machine(ros)}; {count} trips a state, timeout {TIMEOUT * 1000:.0f} ms; "
            f"{hostile_run['sent']:,} hostile messages.\n\n{table(checks)}\n\n" + "\n".join(target_lines(checks))
            + f"\n\nWhole run: {time.monotonic() - began:.0f} s.\n")
    keep(f"{ros.lower().replace(' ', '')}_guard", checks)
    print(text)
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / f"guard_{ros.lower().replace(' ', '')}.md").write_text(text)
    return int(any(f.passed is False for f in checks))


if __name__ == "__main__":
    sys.exit(main())
