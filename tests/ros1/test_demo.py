"""The demo robot: its nodes' behaviour, its launch files, starting it in one call or with %demo.

The nodes run as real processes on the test master, started the way a user starts
them (``demo_robot``); the pytest process watches and drives them through DSL nodes of
its one ROS node. Every test stops what it started (conftest's guard checks).
"""

from __future__ import annotations

import math
import os
import subprocess
import time

import numpy as np
import pytest
from helpers import one_call
from geometry_msgs.msg import Pose, PoseStamped, Twist, Vector3
from IPython.core.error import UsageError
from ros1_fixtures import ros1_process, wait_for
from shell import error_of, ok
from std_msgs.msg import Bool

from ipyros.core.errors import BaseNodeError
from ipyros.demo import DEMO_DIR
from ipyros.ros1.nodes import find_executable
from ipyros.tools.robot import (
    ROBOTS,
    DemoRobotError,
    demo_robot,
    launch_args,
    read_launch,
    running_robot,
    stop_demo_robot,
)


@pytest.fixture
def robot_stopper():
    """Stops whatever demo robot a test started, even when it fails half-way."""
    yield
    stop_demo_robot()


class Track:
    """Poses of the robot (arrival time, x, y, yaw), as a DSL node receives them."""

    def __init__(self) -> None:
        self.poses: list[tuple[float, float, float, float]] = []

    def __call__(self, msg: Pose) -> None:
        q = msg.orientation
        self.poses.append((time.monotonic(), msg.position.x, msg.position.y, 2 * math.atan2(q.z, q.w)))

    def since(self, start: float) -> np.ndarray:
        return np.array([p for p in self.poses if p[0] >= start])


class Driver:
    """Commands (v, w) on a topic ten times a second from ``node``'s timer ``drive``; counts what it sent."""

    def __init__(self, node, topic: str) -> None:
        self.node, self.topic = node, topic
        self.sent: list[tuple[float, float, float]] = []  # (time, v, w)

    def drive(self, v: float, w: float) -> None:
        def send() -> None:
            self.node.write(self.topic, Twist(linear=Vector3(x=v), angular=Vector3(z=w)))
            self.sent.append((time.monotonic(), v, w))

        self.node.timer(0.1, send, name="drive")  # the same name each time: the timer is replaced

    def first(self, v: float, w: float) -> float:
        """When the first (v, w) command went out (waiting for it)."""
        return wait_for(lambda: next((t for t, sv, sw in self.sent if (sv, sw) == (v, w)), None),
                        what=f"a ({v}, {w}) command")

    def count(self, v: float, w: float) -> int:
        return sum((sv, sw) == (v, w) for _, sv, sw in self.sent)


def fit_circle(xy: np.ndarray) -> float:
    """The radius of the least-squares circle through the points (x² + y² = 2ax + 2by + c)."""
    A = np.c_[2 * xy, np.ones(len(xy))]
    (a, b, c), *_ = np.linalg.lstsq(A, (xy ** 2).sum(axis=1), rcond=None)
    return math.sqrt(c + a * a + b * b)


# -- turtle_sim: kinematics and noise ----------------------------------------------------------

def test_turtle_drives_a_straight_line_then_a_circle_of_radius_v_over_w(ros_session, make_node, robot_stopper):
    robot = demo_robot("turtle")
    assert robot.running and list(robot.processes) == ["/turtle_sim"]
    track = Track()
    nd = make_node("kinematics")
    nd.new.subscribe("/turtle1/pose", handler=track, msgType=Pose).publish("/turtle1/cmd_vel", msgType=Twist)
    nd.create()
    wait_for(lambda: len(track.poses) > 3, what="poses")
    assert track.poses[-1][1:] == (0.0, 0.0, 0.0)  # it stands at the origin until told otherwise

    # Straight ahead at 1 m/s: along x, heading unchanged, at the commanded speed.
    driver = Driver(nd, "/turtle1/cmd_vel")
    driver.drive(1.0, 0.0)
    start = driver.first(1.0, 0.0) + 0.2  # the command on its way, the next pose out
    wait_for(lambda: track.poses[-1][0] > start + 1.0, what="a second of driving")
    line = track.since(start)
    assert np.abs(line[:, 2]).max() < 1e-9 and np.abs(line[:, 3]).max() < 1e-9
    speed = (line[-1, 1] - line[0, 1]) / (line[-1, 0] - line[0, 0])
    assert speed == pytest.approx(1.0, rel=0.1)

    # A circle: v = 2 m/s, w = 4 rad/s, so r = v/w = 0.5 m, once round in 2π/w = 1.6 s.
    driver.drive(2.0, 4.0)
    start = driver.first(2.0, 4.0) + 0.2
    wait_for(lambda: track.poses[-1][0] > start + 1.2 * 2 * math.pi / 4.0, what="a round and a bit")
    assert fit_circle(track.since(start)[:, 1:3]) == pytest.approx(0.5, rel=0.03)
    nd.shutdown()
    robot.stop()
    assert not robot.running and running_robot() is None


def test_noise_scatters_the_published_pose_only(ros_session, make_node, robot_stopper):
    demo_robot("turtle", noise=0.05)
    track = Track()
    make_node("noisy").new.subscribe("/turtle1/pose", handler=track, msgType=Pose).create()
    wait_for(lambda: len(track.poses) >= 60, what="60 poses")
    xy = track.since(0)[:, 1:3]
    assert 0.03 < xy.std() < 0.08  # standing still, around the origin: the noise is the sensor's
    assert abs(xy.mean()) < 0.03


# -- the Kobuki set: speed monitor, and the whole launch file driving to a goal ----------------

def test_speed_monitor_fires_above_max_speed_only_and_resets_when_commands_stop(ros_session, make_node,
                                                                                 robot_stopper):
    robot = demo_robot("kobuki")  # the base and the monitor; no planner
    assert list(robot.processes) == ["/mobile_base", "/speed_monitor"]
    flags: list[bool] = []
    nd = make_node("speeder")
    (nd.new.subscribe("/speed_exceeded", handler=lambda m: flags.append(m.data), msgType=Bool)
          .publish("/mobile_base/commands/velocity", msgType=Twist)
          .create())
    wait_for(lambda: flags == [False], what="the latched 'not exceeded'")

    driver = Driver(nd, "/mobile_base/commands/velocity")
    driver.drive(5.0, 0.0)  # at the limit is not above it
    wait_for(lambda: driver.count(5.0, 0.0) >= 5, what="5 commands at 5.0 m/s")
    assert flags == [False]

    driver.drive(5.1, 0.0)
    wait_for(lambda: flags == [False, True], what="the monitor to fire at 5.1 m/s")
    log = robot.processes["/speed_monitor"]
    wait_for(lambda: any("speed 5.10 m/s exceeds max_speed 5.00 m/s" in line for line in log.tail(10)),
             what="the monitor's warning")

    nd.remove(timer="drive")  # no commands: after ~cmd_timeout (1 s) the robot stands, and so the flag drops
    wait_for(lambda: flags == [False, True, False], timeout=5, what="the monitor to reset")


def test_the_whole_kobuki_launch_drives_to_a_goal(ros_session, make_node, robot_stopper):
    """planner:=true relay:=true: move_base, topic_tools/relay and the base, wired by the launch file alone."""
    robot = demo_robot("kobuki", planner=True, relay=True, speed=2.0)
    assert list(robot.processes) == ["/mobile_base", "/speed_monitor", "/move_base", "/cmd_vel_relay"]
    track = Track()
    goal = PoseStamped()
    goal.pose.position.x, goal.pose.position.y = 1.0, -1.0
    nd = make_node("navigator")
    (nd.new.subscribe("/turtle1/pose", handler=track, msgType=Pose)
          .publish("/move_base_simple/goal", msgType=PoseStamped, latch=True)
          .create())
    nd.write("/move_base_simple/goal", goal)
    wait_for(lambda: any("goal reached" in line for line in robot.processes["/move_base"].tail(5)), timeout=30,
             what="move_base to reach its goal")
    x, y = track.poses[-1][1:3]
    assert math.hypot(x - 1.0, y + 1.0) < 0.15


# -- the API: one robot at a time, its parameters, its errors ---------------------------------

def test_one_robot_at_a_time_and_the_same_one_again(ros_session, robot_stopper, ros_master):
    turtle = demo_robot("turtle", max_speed=2.0)
    master = one_call(ros_master)
    assert master.getParam("/t", "/turtle_sim/max_speed")[2] == 2.0  # the launch file's params, set on the master
    assert demo_robot("turtle", max_speed=2.0) is turtle  # the same robot, same arguments: kept running
    pid = turtle.processes["/turtle_sim"].pid
    kobuki = demo_robot("kobuki")  # another one: the first stops
    assert not turtle.running and not turtle.processes and kobuki.running
    wait_for(lambda: not os.path.exists(f"/proc/{pid}"), what="turtle_sim to be gone")
    assert master.hasParam("/t", "/turtle_sim/max_speed")[2] is False  # its params went with it
    assert running_robot() is kobuki
    assert stop_demo_robot() is kobuki and stop_demo_robot() is None
    assert running_robot() is None


def test_bad_robot_names_and_arguments_are_one_line_errors(ros_session):
    with pytest.raises(DemoRobotError, match="no demo robot 'kobukki'; did you mean kobuki"):
        demo_robot("kobukki")
    with pytest.raises(DemoRobotError, match="kobuki.launch has no argument 'max_sped'; did you mean max_speed"):
        demo_robot("kobuki", max_sped=3)
    with pytest.raises(DemoRobotError, match="kobuki.launch: perhaps is not a 'bool' type"):
        demo_robot("kobuki", planner="perhaps")  # if="$(arg planner)" wants a boolean
    assert running_robot() is None


def test_a_node_name_already_live_elsewhere_is_refused(ros_session, ros_master, robot_stopper):
    other = ros1_process(find_executable("ipyros_demo", "turtle_sim"), master_uri=ros_master).start()
    try:
        wait_for(lambda: node_pid(ros_master, "/turtle_sim") == other.pid, what="the other turtle_sim to register")
        with pytest.raises(BaseNodeError, match=r"node /turtle_sim already runs at http://.* \(another session's demo robot\?\); stop it there"):
            demo_robot("turtle")
        assert other.running  # left alone (the master would have shut it down for a namesake)
    finally:
        other.stop()


def node_pid(master_uri: str, name: str):
    """The pid of the live node the master knows as ``name``, or None."""
    code, _, uri = one_call(master_uri).lookupNode("/t", name)
    try:
        return one_call(uri).getPid("/t")[2] if code == 1 else None
    except OSError:
        return None


def test_a_node_that_dies_is_reported(ros_session, robot_stopper):
    notices: list[str] = []
    previous, ros_session.notice = ros_session.notice, notices.append
    try:
        robot = demo_robot("turtle")
        os.kill(robot.processes["/turtle_sim"].pid, 9)
        wait_for(lambda: notices, what="the report")
        assert "demo robot turtle: node turtle_sim killed by SIGKILL" in notices[0]
    finally:
        ros_session.notice = previous


def test_launch_files_read_as_roslaunch_reads_them():
    nodes, params = read_launch(ROBOTS["kobuki"].path, {"planner": True, "max_speed": 3})
    assert [(n.name, n.package, n.executable) for n in nodes] == [
        ("/mobile_base", "ipyros_demo", "turtle_sim"), ("/speed_monitor", "ipyros_demo", "speed_monitor"),
        ("/move_base", "ipyros_demo", "move_base")]
    assert nodes[0].remaps == {"turtle1/cmd_vel": "mobile_base/commands/velocity",
                               "turtle1/bumper": "mobile_base/events/bumper"}
    assert params["/mobile_base/max_speed"] == params["/speed_monitor/max_speed"] == 3.0
    assert {a.name for a in launch_args(ROBOTS["kobuki"].path)} == {"max_speed", "wall", "noise", "speed", "planner",
                                                                    "relay"}
    # roslaunch itself runs them too, with ipyros/ on ROS_PACKAGE_PATH (as the launch files say).
    env = {**os.environ, "ROS_PACKAGE_PATH": str(DEMO_DIR.parent)}
    listed = subprocess.run(["roslaunch", "--nodes", str(ROBOTS["kobuki"].path), "relay:=true"], env=env,
                            capture_output=True, text=True, timeout=60, check=True).stdout.split()
    assert listed == ["/mobile_base", "/speed_monitor", "/move_base", "/cmd_vel_relay"]


# -- %demo ----------------------------------------------------------------------------------

def test_demo_magic_starts_lists_and_stops(ip, capsys, robot_stopper):
    ok(ip, "%demo")
    out = capsys.readouterr().out
    assert "demo robot turtle (running) from turtle.launch" in out and "/turtle_sim" in out
    assert 'nd = rosNode("turtle_control_node")' in out  # what to type next
    assert running_robot().kind == "turtle"

    ok(ip, "%demo --list")
    out = capsys.readouterr().out
    assert "turtle" in out and "kobuki" in out and "planner:=false" in out and "max_speed:=5.0" in out

    ok(ip, "%demo kobuki max_speed:=4.0")
    assert running_robot().kind == "kobuki" and running_robot().params["/speed_monitor/max_speed"] == 4.0
    out = capsys.readouterr().out
    assert "%pub /move_base_simple/goal" in out
    assert "ipyros: the demo robot turtle was stopped first: one demo robot runs at a time" in out, "said, not silent"

    ok(ip, "%demo --stop")
    assert "demo robot kobuki stopped" in capsys.readouterr().out
    ok(ip, "%demo --stop")
    assert "no demo robot is running" in capsys.readouterr().out


def test_demo_magic_errors(ip):
    assert isinstance(error_of(ip, "%demo kobuki fast"), UsageError)
    assert "name:=value" in str(error_of(ip, "%demo kobuki fast"))
    assert "take no robot" in str(error_of(ip, "%demo kobuki --stop"))
    error = error_of(ip, "%demo kobuki bogus:=1")
    assert isinstance(error, DemoRobotError) and "has no argument 'bogus'" in str(error)
    assert running_robot() is None
