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
from std_msgs.msg import Bool, String
from std_srvs.srv import Empty
from test_export import export_env, running, world

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
    global cpp
    cpp = make_node("cpp_wrap", namespace=ns)
    (cpp.baseNode("echo_node", args=["--prefix", "echo> "], params={"exit_after": 0})
        .basePackage("ipyros_test_nodes"))
    cpp.reuse.subscribe("in", type=String).publish("out", type=String).service("~reset", type=Empty)
    cpp.reuse.publish("cmd", type=Twist)
    cpp.guard("cmd", limits={"linear.x": (-0.5, 0.5)}, rate={"angular.z": 100.0}, timeout=0.3,
              stop={"angular": {"z": 0.0}}, estop_topic="/cpp_estop")
    cpp.new.subscribe("chatter", handler=shout_cpp, type=String).publish("loud", type=String)
    cpp.new.publish("~tick", type=String)
    cpp.timer(0.5, tick_cpp, name="tick")
    cpp.params["volume"] = 11
    return cpp


def export_cpp(node, target):
    """The package, and what the export said (its own warnings: not another's, such as a ResourceWarning of a socket
    some earlier test left to the garbage collector, which may fall due in the middle)."""
    from ipyros.files.export import ExportWarning

    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        package = node.export(target, language="cpp")
    return package, [str(w.message) for w in said if issubclass(w.category, ExportWarning)]


def test_the_package_holds_cpp_boilerplate_and_says_what_to_port(make_node, tmp_path):
    package, said = export_cpp(cpp_node(make_node, "/cpp_files"), tmp_path / "cpp_pkg")
    files = sorted(p.relative_to(package).as_posix() for p in package.rglob("*") if p.is_file())
    assert files == ["CMakeLists.txt", "PORTING.md", "launch/cpp_wrap.launch", "package.xml", "src/cpp_wrap.cpp"]
    assert said == ["ipyros: cpp_pkg's C++ has 2 handler(s) to port by hand (shout_cpp, tick_cpp): their Python "
                    "source is beside each method; see cpp_pkg/PORTING.md"]
    source = (package / "src" / "cpp_wrap.cpp").read_text()
    assert "  // def shout_cpp(msg):" in source and "void shout_cpp(const std_msgs::String::ConstPtr& msg)" in source
    assert "constexpr uint32_t kQueue = 0;" in source and "&CppWrapNode::shout_cpp, this, noDelay());" in source
    assert "topic_tools::ShapeShifter" in source and "createSteadyTimer" in source  # byte relays; steady watch
    porting = (package / "PORTING.md").read_text()
    assert "| `shout_cpp` | Subscribe | `/cpp_files/chatter` | `String`, `suffix` |" in porting
    manifest = (package / "package.xml").read_text()
    assert "<depend>roscpp</depend>" in manifest and "<depend>geometry_msgs</depend>" in manifest
    assert "<exec_depend>ipyros_test_nodes</exec_depend>" in manifest  # the basenode: run, not built against
    with pytest.raises(IpyrosError, match=r"C\+\+ goes in a package: give a directory"):
        cpp.export(tmp_path / "node.py", language="cpp")
    with pytest.raises(IpyrosError, match="give 'python' or 'cpp'"):
        cpp.export(tmp_path / "x_pkg", language="rust")


def test_catkin_make_builds_it_and_the_compiled_node_relays_and_guards(make_node, tmp_path, ros_master, no_ipyros):
    ns = "/cpp_built"
    node = cpp_node(make_node, ns)
    workspace = tmp_path / "ws"
    export_cpp(node, workspace / "src" / "cpp_built_pkg")
    built = subprocess.run(["catkin_make", "-C", str(workspace), f"-DPYTHON_EXECUTABLE={ROS1_PYTHON}"],
                           check=False, capture_output=True, text=True, timeout=600)
    assert built.returncode == 0, built.stdout[-3000:] + built.stderr[-3000:]
    assert os.access(workspace / "devel" / "lib" / "cpp_built_pkg" / "cpp_wrap", os.X_OK)
    env = export_env(workspace / "src", no_ipyros)
    env["CMAKE_PREFIX_PATH"] = os.pathsep.join([str(workspace / "devel"), os.environ.get("CMAKE_PREFIX_PATH", "/usr")])
    internal_cmd = internal_name(node.model(), f"{ns}/cmd")
    with running(["roslaunch", "cpp_built_pkg", "cpp_wrap.launch"], env) as launch:
        driver, heard = world(make_node, ns, {f"{ns}/in": String, internal_cmd: Twist},
                              {f"{ns}/out": String, f"{ns}/cmd": Twist})
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
