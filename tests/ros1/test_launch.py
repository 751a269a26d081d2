"""Wrapping a node that a launch file starts: the rest of the file runs untouched, the node wrapped in place.

tests/launch/robot.launch: /robot1/in → planner → /robot1/plan → controller → /commands
→ logger → /log, every node an echo_node that prefixes what it echoes. The planner
(private params, a remap out:=plan) is wrapped; roslaunch runs the controller and the
included logger as the file says.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
import rosnode
from helpers import one_call, pid_alive
from ros1_fixtures import master_state, wait_for
from std_msgs.msg import Int32, String

from ipyros.core import errors
from ipyros.core.model import NodeModel
from ipyros.core.remapping import basenode_remaps
from ipyros.dsl import engine_of

LAUNCH = Path(__file__).resolve().parents[1] / "launch"
ROBOT = str(LAUNCH / "robot.launch")
PLANNER_PARAMS = {"rate": 5, "frame": "map", "gains": {"p": 1.5, "i": 0.25}}


def listen(make_node, name, topic, type_=String):
    """A DSL node in this process that collects what arrives on ``topic``."""
    seen: list = []
    make_node(name).new.subscribe(topic, handler=seen.append, msgType=type_).create()
    return seen


def node_names() -> set[str]:
    """What ``rosnode list`` shows."""
    return set(rosnode.get_node_names())


def node_pid(name: str) -> int:
    """The pid of a running ROS node, asked from the node itself (as ``rosnode info`` does)."""
    uri = rosnode.get_api_uri(rosnode.rosgraph.Master("/pytest"), name, skip_cache=True)
    return one_call(uri).getPid("/pytest")[2]


def processes_named(node_name: str, master_uri: str = "") -> list[int]:
    """Pids of processes started as ROS node ``node_name`` (``__name:=...`` in their argv) on this test's master
    (``ROS_MASTER_URI`` in their environment: this run's, or ``master_uri``), and on no other: a person's own ROS
    session beside the suite may run nodes of the same names."""
    master = (master_uri or os.environ.get("ROS_MASTER_URI", "")).encode()
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            argv = (entry / "cmdline").read_bytes().split(b"\0")
            if f"__name:={node_name}".encode() not in argv:
                continue
            environ = (entry / "environ").read_bytes().split(b"\0")
        except OSError:
            continue
        if b"ROS_MASTER_URI=" + master in environ and pid_alive(int(entry.name)):
            found.append(int(entry.name))
    return found


def test_a_launch_node_read_as_a_basenode(make_node):
    nd = make_node("planner_reader")
    nd.baseLaunch(ROBOT, "/robot1/planner")
    base = nd.model().base
    assert (base.package, base.executable, base.node_name, base.namespace) == \
        ("ipyros_test_nodes", "echo_node", "planner", "/robot1/")
    assert base.remaps == {"/robot1/out": "/robot1/plan"}
    assert base.params == PLANNER_PARAMS  # <param> and <rosparam> inside the node, nested again
    assert base.args == ["--prefix", "planned: "]  # the arg's default, substituted by roslaunch
    assert (base.launch, base.launch_node) == (ROBOT, "/robot1/planner")
    assert nd.fullname == "/robot1/planner_reader", "the wrapper lives in its basenode's namespace"
    assert NodeModel.from_dict(nd.model().to_dict()) == nd.model()

    # Short and relative names find the same node; base names resolve through the launch's remaps.
    for name in ("planner", "robot1/planner"):
        assert make_node("planner_reader_" + name.replace("/", "_")).baseLaunch(ROBOT, name).model().base == base
    assert make_node("planner_reader_path").baseLaunch(Path(ROBOT), "planner").model().base == base
    nd.reuse.publish("out", type=String).subscribe("in", type=String)
    assert {t.name: t.resolved for t in nd.model().topics} == {"out": "/robot1/plan", "in": "/robot1/in"}


def test_one_remap_per_name_composes_the_launch_remaps_with_the_wrapping(make_node):
    """ROS applies one remap to a name: the basenode's own ``cmd_vel:=base/cmd_vel`` must become
    ``cmd_vel:=<internal>`` when base/cmd_vel is wrapped, not stay and be followed by another."""
    nd = make_node("remap_wrap")
    nd.baseNode("echo_node", namespace="robot1", remaps={"cmd_vel": "base/cmd_vel", "odom": "/odom_raw",
                                                          "scan": "/scan_front"}).basePackage("ipyros_test_nodes")
    nd.reuse.publish("/robot1/base/cmd_vel", type=String)  # the world's name, the target of a remap
    nd.reuse.subscribe("odom", type=String)  # the basenode's own name, remapped
    internal = "/robot1/remap_wrap/base"
    assert [t.resolved for t in nd.model().topics] == ["/robot1/base/cmd_vel", "/odom_raw"]
    assert basenode_remaps(nd.model()) == {
        "/robot1/cmd_vel": internal + "/robot1/base/cmd_vel",
        "/robot1/odom": internal + "/odom_raw",
        "/robot1/scan": "/scan_front",  # not wrapped: as declared
        "/robot1/base/cmd_vel": internal + "/robot1/base/cmd_vel",  # in case the node uses the name itself
        "/odom_raw": internal + "/odom_raw",
    }


def test_wrapping_a_node_of_a_launch_file(make_node, ros_master):
    commands = listen(make_node, "launch_commands_listener", "/commands")
    logged = listen(make_node, "launch_log_listener", "/log")
    feeder = make_node("launch_feeder").new.publish("/robot1/in", msgType=String).create()
    send = lambda text: feeder.write("/robot1/in", String(text))  # noqa: E731

    nd = make_node("planner_wrap")
    nd.baseLaunch(ROBOT, "/robot1/planner")
    nd.reuse.subscribe("in", type=String).publish("out", type=String)
    nd.create()
    master = one_call(ros_master)
    try:
        # The rest of the launch runs as the file says; the planner runs where it was, with its params.
        assert {"/robot1/planner", "/robot1/controller", "/logger"} <= node_names()
        assert master.getParam("/pytest", "/robot1/planner")[2] == PLANNER_PARAMS
        assert master.getParam("/pytest", "/logger/level")[2] == "info"  # the included file's param
        assert master.getParam("/pytest", "/robot_description")[2] == "a tiny test robot"
        state = master_state(ros_master)
        assert state["sub"]["/robot1/planner_wrap/base/robot1/in"] == ["/robot1/planner"]
        assert state["pub"]["/robot1/planner_wrap/base/robot1/plan"] == ["/robot1/planner"]
        assert "/robot1/planner" not in state["pub"].get("/robot1/plan", []), "the launch remap was composed"

        # Through the wrap: planner, then the controller and logger of the rest.
        wait_for(lambda: send("x") or logged, timeout=20, what="a message through the whole launch")
        assert logged[0].data == "logged: executing: planned: x"

        # A handler of the wrapping node takes the planner's output over, live.
        nd.new.publish("/robot1/plan", msgType=String)
        nd.new.subscribe("/robot1/plan", handler=lambda m: nd.write("/robot1/plan", String(m.data.upper())),
                         msgType=String)
        wait_for(lambda: send("y") or any(m.data == "executing: PLANNED: Y" for m in commands), timeout=20,
                 what="the handler between the planner and the controller")

        pids = {name: node_pid(name) for name in ("/robot1/planner", "/robot1/controller", "/logger")}
        runner = nd.base.rest.pid
        assert pids["/robot1/planner"] == nd.base.pid
        assert "/robot1/planner" in repr(nd.base) and nd.base.rest.running
    finally:
        nd.shutdown()
    assert nd.base is None
    wait_for(lambda: not any(map(pid_alive, [*pids.values(), runner])), timeout=15, what="every process to exit")
    wait_for(lambda: not node_names() & set(pids), timeout=10, what="the nodes to unregister")


def test_a_failure_half_way_leaves_nothing_running(make_node):
    nd = make_node("wrong_type_wrap")
    nd.baseLaunch(ROBOT, "/robot1/planner")
    nd.reuse.publish("out", type=Int32)  # the planner publishes std_msgs/String
    with pytest.raises(errors.TopicTypeConflict, match="declare type='std_msgs/String'"):
        nd.create()
    assert nd.base is None and not nd.created
    for name in ("planner", "controller", "logger"):
        wait_for(lambda name=name: not processes_named(name), timeout=15, what=f"{name} to be stopped")


def test_wrapping_the_only_node_and_a_rest_roslaunch_cannot_start(make_node, ros_master, ros_session):
    """The rest is a param and a node roslaunch cannot find: it keeps running, and the user is told."""
    notices: list[str] = []
    previous, ros_session.notice = ros_session.notice, notices.append
    try:
        nd = make_node("alone_wrap")
        nd.baseLaunch(str(LAUNCH / "alone.launch"), "alone")
        nd.create()
        master = one_call(ros_master)
        assert master.getParam("/pytest", "/alone_mode")[2] == "solo"
        assert master.getParam("/pytest", "/alone/exit_code")[2] == 4
        assert "/alone" in node_names()
        assert any("could not start /ghost" in n for n in notices), notices
        runner = nd.base.rest.pid
        assert nd.base.rest.running, "a rest without nodes still runs until the node shuts down"
        nd.shutdown()
        wait_for(lambda: not pid_alive(runner), timeout=10, what="the rest's runner to exit")
        assert not any("exited" in n for n in notices), "a stop that was asked for is no news"
    finally:
        ros_session.notice = previous


@pytest.mark.parametrize("launch, node, message", [
    ("no/such.launch", "planner", r"launch file 'no/such.launch' not found \(relative to .*\); give its path"),
    ("$(find no_such_pkg)/robot.launch", "planner", "no ROS package 'no_such_pkg'"),
    (str(LAUNCH / "broken.launch"), "planner", "roslaunch cannot load .*broken.launch: Invalid roslaunch XML syntax"),
    (str(LAUNCH / "needs_arg.launch"), "planner", r"launch file needs_arg.launch needs arg robot \(no default\); "
                                                  r"give it: baseLaunch\('needs_arg.launch', node, robot=...\)"),
    (ROBOT, "/robot1/planer", ("starts no node '/robot1/planer': did you mean /robot1/planner.* its nodes: "
                               "/logger, /robot1/controller, /robot1/planner")),
    (ROBOT, "navigator", "starts no node 'navigator': its nodes: /logger"),
    (ROBOT, "", "node name '' is empty"),
    (str(LAUNCH / "features.launch"), "relay", "has 2 nodes named 'relay': /left/relay, /right/relay; give the full"),
    (str(LAUNCH / "features.launch"), "remote_echo", "runs on machine 'far' .*this machine only"),
    (str(LAUNCH / "features.launch"), "debugged_echo", "launch-prefix='gdb -ex run --args'.*cannot apply it"),
])
def test_bad_launch_input_is_one_line_and_changes_nothing(make_node, launch, node, message):
    nd = make_node("bad_launch_wrap")
    with pytest.raises(errors.BaseNodeError, match=message) as caught:
        nd.baseLaunch(launch, node)
    assert "\n" not in str(caught.value)
    assert nd.model().base is None and nd.fullname == "/bad_launch_wrap"


def test_launch_args_are_given_like_roslaunch_file_name_value(make_node, ros_master, tmp_path):
    from ipyros import rosNode

    with pytest.raises(errors.BaseNodeError) as caught:
        make_node("arg_typo").baseLaunch(ROBOT, "planner", prefx="fast: ")
    assert str(caught.value) == "launch file robot.launch has no arg prefx; did you mean prefix? its args: prefix"
    with pytest.raises(errors.DeclarationError, match="give a dict of the launch file's args"):
        make_node("arg_list").baseLaunch(ROBOT, "planner", args=["prefix:=x"])

    out = listen(make_node, "arg_listener", "/out")
    feeder = make_node("arg_feeder").new.publish("/in", msgType=String).create()
    nd = make_node("r2_wrap").baseLaunch(str(LAUNCH / "needs_arg.launch"), "r2_planner", robot="r2")
    assert nd.model().base.launch_args == {"robot": "r2"} and nd.basenode_name == "/r2_planner"
    nd.reuse.subscribe("in", type=String).publish("out", type=String)
    nd.save(tmp_path / "r2.py")
    assert "args={'robot': 'r2'}" in (tmp_path / "r2.py").read_text()
    nd.save(tmp_path / "r2.yaml")
    try:
        nd.create()
        wait_for(lambda: master_state(ros_master)["sub"].get("/r2_wrap/base/in") == ["/r2_planner"],
                 what="the planner named from the arg, remapped onto the wrapper")
        wait_for(lambda: feeder.write("/in", String("x")) or out, timeout=20, what="a message through it")
    finally:
        nd.shutdown()
    again = rosNode.load(tmp_path / "r2.yaml", session=engine_of(nd).session, trust=True)
    assert again.model().base.launch_args == {"robot": "r2"} and again.basenode_name == "/r2_planner"


def test_what_ipyros_runs_differently_is_said_and_the_full_name_picks_one(make_node, ros_session):
    notices: list[str] = []
    previous, ros_session.notice = ros_session.notice, notices.append
    try:
        nd = make_node("respawn_wrap").baseLaunch(str(LAUNCH / "features.launch"), "respawning_echo")
    finally:
        ros_session.notice = previous
    assert nd.model().base.env == {"ECHO_MOOD": "cheerful"}
    assert any('respawn="true"' in n and "instead of respawning" in n for n in notices), notices
    assert make_node("left_wrap").baseLaunch(str(LAUNCH / "features.launch"), "/left/relay").fullname == \
        "/left/left_wrap"


def test_base_launch_is_a_declaration(make_node):
    nd = make_node("late_launch_wrap").new.publish("/late", msgType=String).create()
    with pytest.raises(errors.DeclarationError, match="already running; declare its basenode before create"):
        nd.baseLaunch(ROBOT, "planner")


def test_the_runner_refuses_to_start_a_master(tmp_path):
    """The rest runs on the session's master only: with none there, the runner says so and starts nothing."""
    from ros1_fixtures import free_port

    uri = f"http://127.0.0.1:{free_port()}/"
    env = {**os.environ, "ROS_MASTER_URI": uri}
    done = subprocess.run([sys.executable, "-m", "ipyros.ros1.launch_rest", ROBOT, "--exclude", "/robot1/planner"],
                          env=env, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert "ipyros-launch-rest: failed: no ROS master answers at" in done.stdout
    assert not processes_named("controller", uri)


def test_the_rest_dies_with_its_runner_and_the_user_is_told(make_node, ros_session):
    """Even a SIGKILLed runner leaves no node of the rest behind (roslaunch puts each in a session of its own)."""
    notices: list[str] = []
    previous, ros_session.notice = ros_session.notice, notices.append
    try:
        nd = make_node("runner_kill_wrap").baseLaunch(ROBOT, "planner").create()
        rest_nodes = processes_named("controller") + processes_named("logger")
        assert len(rest_nodes) == 2
        os.kill(nd.base.rest.pid, signal.SIGKILL)
        wait_for(lambda: not any(map(pid_alive, rest_nodes)), timeout=10, what="the rest's nodes to die with it")
        wait_for(lambda: any("the rest of" in n and "killed by SIGKILL" in n for n in notices), timeout=10,
                 what="the news")
        assert nd.base.running, "the basenode itself keeps running"
        nd.shutdown()
    finally:
        ros_session.notice = previous


SCRIPT = """
import sys
from ipyros import rosNode
w = rosNode("orphan_launch_wrap")
w.baseLaunch(sys.argv[1], "planner").create()
print("PIDS", w.base.pid, w.base.rest.pid, flush=True)
if sys.argv[2] == "wait":
    sys.stdin.read()
"""


@pytest.mark.parametrize("ending", ["exit", "SIGKILL"])
def test_no_orphan_when_the_interpreter_ends(ros_master, ending):
    proc = subprocess.Popen([sys.executable, "-c", SCRIPT, ROBOT, "wait" if ending == "SIGKILL" else "exit"],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                            env=dict(os.environ))
    try:
        line = proc.stdout.readline()  # type: ignore[union-attr]
        assert line.startswith("PIDS"), line
        pids = [int(p) for p in line.split()[1:]] + processes_named("controller") + processes_named("logger")
        assert len(pids) == 4
        if ending == "SIGKILL":
            proc.kill()
        assert proc.wait(30) in (0, -signal.SIGKILL)
        wait_for(lambda: not any(map(pid_alive, pids)), timeout=15, what=f"everything to stop at {ending}")
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def test_discovery_of_a_launch_node_finds_its_names_after_the_launch_remaps(make_node):
    nd = make_node("planner_disc_wrap").baseLaunch(ROBOT, "planner")
    nd.discover()
    declared = {(t.name, t.resolved, t.direction) for t in nd.model().topics}
    assert {("in", "/robot1/in", "subscribe"), ("plan", "/robot1/plan", "publish")} <= declared
    assert basenode_remaps(nd.model())["/robot1/out"] == "/robot1/planner_disc_wrap/base/robot1/plan"


def test_a_sibling_from_ipyros_demo_starts_with_the_rest(make_node, tmp_path, ros_session):
    """The rest of a launch file may run ipyros_demo's robot beside the wrapped node: roslaunch finds the package
    as ipyros does (issue 24)."""
    launch = tmp_path / "with_demo.launch"
    launch.write_text('<launch>\n'
                      '  <node pkg="ipyros_demo" type="turtle_sim" name="sibling_turtle"/>\n'
                      '  <node pkg="ipyros_test_nodes" type="echo_node" name="sibling_echo"/>\n'
                      '</launch>\n')
    nd = make_node("sibling_wrap").baseLaunch(str(launch), "sibling_echo")
    nd.create()
    try:
        wait_for(lambda: "/sibling_turtle" in node_names(), timeout=30,
                 what=f"the demo turtle of the rest (its log: {nd.base.rest.tail(8)})")
        assert not nd.base.not_started
    finally:
        nd.shutdown()
    wait_for(lambda: "/sibling_turtle" not in node_names(), timeout=15, what="the sibling to stop")
