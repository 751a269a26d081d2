"""``nd.export(DIR, language="cpp")``: a catkin package whose roscpp node catkin_make builds and whose relays,
service relay, parameters and guard hold as they did in the session; its handlers wait, as comments, to be
ported by hand (PORTING.md lists them).

The wrapping node wraps echo_node (``in`` and ``out`` relayed, its ``~reset`` service relayed) and relays a
``cmd`` output under a guard; the test publishes the basenode's ``cmd`` on its internal name, as the relay
bench does, and a plain subscriber checks what the compiled node lets out.
"""

from __future__ import annotations

import math
import os
import subprocess
import warnings

import pytest
from geometry_msgs.msg import Twist, Vector3
from ros1_fixtures import ROS1_PYTHON, wait_for
from sensing import Sensors, approach
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Bool, String
from std_srvs.srv import Empty
from test_export import export_env, running, world

from ipyros import rule
from ipyros.core.errors import IpyrosError
from ipyros.core.plan import internal_name
from ipyros.ros1 import params as param_server

cpp = None  # the node the handler writes with


def shout_cpp(msg):
    cpp.write("loud", String(msg.data.upper() + suffix))


suffix = "!"


def tick_cpp():
    cpp.write("~tick", String("tick"))


def cpp_node(make_node, ns: str):
    """The node to export, and a node of this session publishing what its guard's rules read (a laser, a bumper),
    created first: the export subscribes to them with the types the live graph shows."""
    global cpp
    sensing = make_node("cpp_sensors", namespace=ns)
    sensing.new.publish("scan", msgType=LaserScan).publish("bumper", msgType=Bool)
    sensing.create()
    cpp = make_node("cpp_wrap", namespace=ns)
    (cpp.baseNode("echo_node", args=["--prefix", "echo> "], params={"exit_after": 0})
        .basePackage("ipyros_test_nodes"))
    cpp.reuse.subscribe("in", type=String).publish("out", type=String).service("~reset", type=Empty)
    cpp.reuse.publish("cmd", type=Twist)
    cpp.guard("cmd", limits={"linear.x": (-0.5, 0.5)}, rate={"angular.z": 100.0}, timeout=0.3,
              stop={"angular": {"z": 0.0}}, estop_topic="/cpp_estop")
    cpp.reuse.publish("drive", type=Twist)  # under rules over what the robot senses, compiled in
    cpp.guard("drive", limits={"linear.x": (-1.0, 1.0)}, stale={f"{ns}/scan": 0.5}, rules=[
        rule(f"min({ns}/scan.ranges) < 0.5", limit={"linear.x": (-0.2, 0.2)}),
        rule(f"{ns}/bumper.data", only="linear.x <= 0"),
        # never true here, compiled all the same: a slice, len, abs, arithmetic, a chain, a field of the command
        rule(f"len({ns}/scan.ranges[0:1]) == 0 or 0 < abs(angular.z) - 2 * {ns}/scan.range_max / 2 < -1",
             scale=0.5, hold=0.5)])
    cpp.new.subscribe("chatter", handler=shout_cpp, type=String).publish("loud", type=String)
    cpp.new.publish("~tick", type=String)
    cpp.timer(0.5, tick_cpp, name="tick")
    cpp.params["volume"] = 11
    return cpp, sensing


def export_cpp(node, target):
    """The package, and what the export said (its own warnings: not another's, such as a ResourceWarning of a socket
    some earlier test left to the garbage collector, which may fall due in the middle)."""
    from ipyros.files.export import ExportWarning

    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        package = node.export(target, language="cpp")
    return package, [str(w.message) for w in said if issubclass(w.category, ExportWarning)]


def test_the_package_holds_cpp_boilerplate_and_says_what_to_port(make_node, tmp_path):
    package, said = export_cpp(cpp_node(make_node, "/cpp_files")[0], tmp_path / "cpp_pkg")
    files = sorted(p.relative_to(package).as_posix() for p in package.rglob("*") if p.is_file())
    assert files == ["CMakeLists.txt", "PORTING.md", "launch/cpp_wrap.launch", "package.xml", "src/cpp_wrap.cpp"]
    assert said == ["ipyros: cpp_pkg's C++ has 2 handler(s) to port by hand (shout_cpp, tick_cpp): their Python "
                    "source is beside each method; see cpp_pkg/PORTING.md"]
    source = (package / "src" / "cpp_wrap.cpp").read_text()
    assert "  // def shout_cpp(msg):" in source and "void shout_cpp(const std_msgs::String::ConstPtr& msg)" in source
    assert "constexpr uint32_t kQueue = 0;" in source and "&CppWrapNode::shout_cpp, this, noDelay());" in source
    assert "topic_tools::ShapeShifter" in source and "createSteadyTimer" in source  # byte relays; steady watch
    assert "// rule 2: when /cpp_files/bumper.data: only linear.x <= 0" in source  # rules compiled in
    porting = (package / "PORTING.md").read_text()
    assert "| `shout_cpp` | Subscribe | `/cpp_files/chatter` | `String`, `suffix` |" in porting
    manifest = (package / "package.xml").read_text()
    assert "<depend>roscpp</depend>" in manifest and "<depend>geometry_msgs</depend>" in manifest
    assert "<exec_depend>ipyros_test_nodes</exec_depend>" in manifest  # the basenode: run, not built against
    with pytest.raises(IpyrosError, match=r"C\+\+ goes in a package: give a directory"):
        cpp.export(tmp_path / "node.py", language="cpp")
    with pytest.raises(IpyrosError, match="give 'python' or 'cpp'"):
        cpp.export(tmp_path / "x_pkg", language="rust")


@pytest.mark.parametrize("condition, said", [
    ("/cpp_refused/scan.ranges == 1", "'/cpp_refused/scan.ranges == 1' compares an array with a number"),
    ("/cpp_refused/scan.header.frame_id == 1", "/cpp_refused/scan.header.frame_id: a string"),
    ("/cpp_refused/bumper.data + 1 > 2", "is a true/false where a number is wanted (always a stop)"),
    ("min(/cpp_refused/scan.ranges, 1) < 2", "min takes one array or numbers"),
    ("len(/cpp_refused/scan.angle_min) > 1", "len of a number"),
    ("/cpp_refused/scan.angle_min", "gives a number, not a true/false"),
])
def test_a_rule_the_cpp_cannot_write_is_refused_at_export_in_one_line(make_node, tmp_path, condition, said):
    sensing = make_node("cpp_refused_sensors")
    sensing.new.publish("/cpp_refused/scan", msgType=LaserScan).publish("/cpp_refused/bumper", msgType=Bool)
    sensing.create()
    nd = make_node("cpp_refused")
    nd.new.publish("/cpp_refused/cmd", msgType=Twist)
    nd.guard("/cpp_refused/cmd", rules=[rule(condition, stop=True)])
    with pytest.raises(IpyrosError) as error:
        nd.export(tmp_path / "refused_pkg", language="cpp")
    assert said in str(error.value) and "export in Python (language='python')" in str(error.value), str(error.value)
    assert "\n" not in str(error.value) and not (tmp_path / "refused_pkg").exists()


def test_catkin_make_builds_it_and_the_compiled_node_relays_and_guards(make_node, tmp_path, ros_master, no_ipyros):
    ns = "/cpp_built"
    node, sensing = cpp_node(make_node, ns)
    workspace = tmp_path / "ws"
    export_cpp(node, workspace / "src" / "cpp_built_pkg")
    built = subprocess.run(["catkin_make", "-C", str(workspace), f"-DPYTHON_EXECUTABLE={ROS1_PYTHON}"],
                           check=False, capture_output=True, text=True, timeout=600)
    assert built.returncode == 0, built.stdout[-3000:] + built.stderr[-3000:]
    assert os.access(workspace / "devel" / "lib" / "cpp_built_pkg" / "cpp_wrap", os.X_OK)
    env = export_env(workspace / "src", no_ipyros)
    env["CMAKE_PREFIX_PATH"] = os.pathsep.join([str(workspace / "devel"), os.environ.get("CMAKE_PREFIX_PATH", "/usr")])
    internal_cmd, internal_drive = (internal_name(node.model(), f"{ns}/{name}") for name in ("cmd", "drive"))
    with running(["roslaunch", "cpp_built_pkg", "cpp_wrap.launch"], env) as launch:
        driver, heard = world(make_node, ns, {f"{ns}/in": String, internal_cmd: Twist, internal_drive: Twist},
                              {f"{ns}/out": String, f"{ns}/cmd": Twist, f"{ns}/drive": Twist})
        out, cmd = heard[f"{ns}/out"], heard[f"{ns}/cmd"]
        wait_for(lambda: driver.write(f"{ns}/in", String("hi")) or out, timeout=60,
                 what=f"echo_node's answer through the compiled relays (output: {launch.lines[-8:]})")
        assert out[-1].data == "echo> hi"
        wait_for(lambda: param_server.has_param(f"{ns}/cpp_wrap/volume"), timeout=10, what="the node's parameter")
        assert param_server.get_param(f"{ns}/cpp_wrap/volume") == 11
        wait_for(lambda: driver.write(internal_cmd, Twist(linear=Vector3(x=3.0))) or
                 any(m.linear.x == 0.5 for m in cmd), timeout=20, interval=0.05, what="the clamped command")
        assert all(m.linear.x <= 0.5 for m in cmd), [m.linear.x for m in cmd]
        cmd.clear()
        driver.write(internal_cmd, Twist(linear=Vector3(x=math.nan)))
        wait_for(lambda: cmd, timeout=10, what="what the guard let out for NaN")
        assert all(math.isfinite(m.linear.x) for m in cmd)
        cmd.clear()  # silence: the stop message, again and again
        wait_for(lambda: len(cmd) >= 3, timeout=10, what="the stop message repeated after the timeout")
        assert all(m.linear.x == 0.0 and m.angular.z == 0.0 for m in cmd)
        driver_estop = make_node("cpp_estop_driver").new.publish("/cpp_estop", msgType=Bool).create()
        wait_for(lambda: driver_estop.write("/cpp_estop", Bool(data=True)) or driver.write(
            internal_cmd, Twist(linear=Vector3(x=0.2))) or (cmd and cmd[-1].linear.x == 0.0 and len(cmd) > 5),
            timeout=10, interval=0.05, what="the e-stop holding the stop message")
        cmd.clear()
        driver.write(internal_cmd, Twist(linear=Vector3(x=0.2)))
        wait_for(lambda: len(cmd) >= 2, timeout=10, what="messages while e-stopped")
        assert all(m.linear.x == 0.0 for m in cmd), "held at the stop message while the e-stop says true"
        answer = subprocess.run([ROS1_PYTHON, "-c", f"import rospy; from std_srvs.srv import Empty; "
                                 f"rospy.wait_for_service('{ns}/echo_node/reset', 10); "
                                 f"rospy.ServiceProxy('{ns}/echo_node/reset', Empty)(); print('called')"],
                                capture_output=True, text=True, timeout=30, env=env)
        assert "called" in answer.stdout, answer.stderr[-2000:]
        check_rules(driver, internal_drive, heard[f"{ns}/drive"], Sensors(sensing, f"{ns}/scan", f"{ns}/bumper"))


def check_rules(driver, internal_drive: str, drive: list, sensors: Sensors) -> None:
    """The compiled guard's rules, as the session's: the stop message while the laser was never heard, the command
    as it came, limited near an obstacle, the stop when one appears with no new command, only backing off while
    the bumper is pressed, the stop message once the laser is stale."""

    def send(x: float, expect: float, what: str) -> None:
        def only_expected() -> bool:  # what went out for one command, once the sensors' change arrived
            drive.clear()
            driver.write(internal_drive, Twist(linear=Vector3(x=x)))
            wait_for(lambda: drive, timeout=10, what=f"{what}: anything")
            return all(m.linear.x == expect for m in list(drive))

        wait_for(only_expected, timeout=20, interval=0.1, what=what)

    try:
        approach(send, sensors)
        sensors.ranges = [2.0, 3.0]
        send(0.4, 0.4, "the command as it came once the obstacle is gone")
        drive.clear()
        sensors.ranges = [0.3, 3.0]  # and no new command: the last, 0.4, would now be limited
        wait_for(lambda: any(m.linear.x == 0.0 for m in drive), timeout=10, what="the stop with no new command")
        sensors.ranges, sensors.pressed = [2.0, 3.0], True
        send(0.3, 0.0, "the stop message for a forward command while the bumper is pressed")
        send(-0.2, -0.2, "backing off while the bumper is pressed")
    finally:
        sensors.stop()
    drive.clear()
    wait_for(lambda: len(drive) >= 3, timeout=10, what="the stop message repeated once the laser is stale")
    assert all(m.linear.x == 0.0 for m in drive), [m.linear.x for m in drive]
