"""``nd.export(DIR)`` on ROS 2: an ament_python package that colcon builds, and whose installed node,
started from its own launch file with ipyros not importable, relays, intercepts, serves (a service
relayed, an action of its own) and guards as the session did.

A first interpreter declares a wrapping node (the basenode ``echo_pkg/echo_node`` from an ament prefix of
the test's own: its ``in`` and service relayed, its ``out`` intercepted by a handler, a timer reading a
parameter, a guarded ``cmd`` the timer writes 3 m/s to) and exports it; ``colcon build`` builds the
package into a workspace; the installed launch file is read (by ipyros's reader, as ``ros2 launch``
would: ``ros2 launch`` is not on PyPI) and each of its nodes runs as a process of its own.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from geometry_msgs.msg import Twist
from ros2_fixtures import wait_for
from sensing import Sensors
from sensor_msgs.msg import LaserScan
from std_msgs.msg import String
from std_srvs.srv import SetBool

ECHO_NODE = Path(__file__).resolve().parent / "peers" / "echo_node.py"

BUILD = '''
import sys
import time
from ipyros import rosNode, rule
from geometry_msgs.msg import Twist, Vector3
from sensor_msgs.msg import LaserScan
from std_msgs.msg import String
from std_srvs.srv import SetBool
def shout(msg):
    nd.write("loud", String(data="v1 " + msg.data))
def beat():
    nd.write("beat", String(data="beat " + str(nd.params["volume"])))
    nd.write("cmd", Twist(linear=Vector3(x=3.0)))
nd = rosNode("keeper", namespace="/kp")
nd.baseNode("echo_node", params={"prefix": "echo> "}).basePackage("echo_pkg")
nd.reuse.subscribe("in", type=String).publish("out", type=String).service("check", type=SetBool)
nd.new.subscribe("out", handler=shout, type=String).publish("loud", type=String).publish("beat", type=String)
nd.new.publish("cmd", type=Twist)
laser = rosNode("kp_laser")  # what the guard's rule reads: its type, the live graph's at export
laser.new.publish("/kp/scan", type=LaserScan)
laser.create()
nd.guard("cmd", limits={"linear.x": (-0.5, 0.5)}, rules=[rule("min(/kp/scan.ranges) < 0.5", stop=True)],
         stale={"/kp/scan": 1.0})
nd.timer(0.2, beat)
def count(goal, action):
    for i in range(1, goal.order + 1):
        action.feedback({"sequence": list(range(i))})
        time.sleep(0.02)
    return {"sequence": list(range(goal.order))}
nd.new.action("count", "test_msgs/Fibonacci", count)
nd.params["volume"] = 11
print("exported", nd.export(sys.argv[1], globals()), flush=True)
'''


@pytest.fixture
def workspace(tmp_path, monkeypatch):
    """A colcon workspace whose src/ holds the exported package, built; echo_pkg in an ament prefix beside it."""
    prefix = tmp_path / "prefix"
    (prefix / "share" / "ament_index" / "resource_index" / "packages").mkdir(parents=True)
    (prefix / "share" / "ament_index" / "resource_index" / "packages" / "echo_pkg").touch()
    (prefix / "lib" / "echo_pkg").mkdir(parents=True)
    (prefix / "lib" / "echo_pkg" / "echo_node").write_text(f"#!{sys.executable}\n" + ECHO_NODE.read_text())
    (prefix / "lib" / "echo_pkg" / "echo_node").chmod(0o755)
    monkeypatch.setenv("AMENT_PREFIX_PATH", os.pathsep.join([str(prefix), os.environ.get("AMENT_PREFIX_PATH", sys.prefix)]))
    ws = tmp_path / "ws"
    (ws / "src").mkdir(parents=True)
    build = tmp_path / "build.py"
    build.write_text(BUILD)
    done = subprocess.run([sys.executable, str(build), str(ws / "src" / "keeper_pkg")], capture_output=True, text=True,
                          timeout=90)
    assert done.returncode == 0 and "exported" in done.stdout, done.stderr[-2000:]
    colcon = Path(sys.executable).with_name("colcon")
    assert colcon.exists(), "colcon is not in this venv: bash run.sh installs colcon-common-extensions"
    built = subprocess.run([str(colcon), "build", "--base-paths", "src", "--build-base", "build",
                            "--install-base", "install"], cwd=ws, capture_output=True, text=True, timeout=300)
    assert built.returncode == 0, built.stdout[-3000:] + built.stderr[-2000:]
    return ws


def test_the_package_has_what_colcon_and_ros2_run_need(workspace):
    src = workspace / "src" / "keeper_pkg"
    manifest = (src / "package.xml").read_text()
    assert '<package format="3">' in manifest and "<build_type>ament_python</build_type>" in manifest
    for needed in ("rclpy", "std_msgs", "std_srvs", "geometry_msgs", "test_msgs", "action_msgs", "echo_pkg"):
        assert f"<exec_depend>{needed}</exec_depend>" in manifest
    installed = workspace / "install" / "keeper_pkg"
    assert (installed / "lib" / "keeper_pkg" / "keeper").exists()  # where ros2 run keeper_pkg keeper looks
    assert (installed / "share" / "ament_index" / "resource_index" / "packages" / "keeper_pkg").exists()
    assert (installed / "share" / "keeper_pkg" / "launch" / "keeper.launch.xml").exists()
    assert "volume: 11" in (installed / "share" / "keeper_pkg" / "config" / "keeper.yaml").read_text()
    module = (src / "keeper_pkg" / "keeper.py").read_text()
    assert "def main():" in module and "import ipyros" not in module and "from ipyros" not in module
    assert "start_basenode" not in module  # in the package its launch file starts the basenode


def test_the_installed_node_started_from_its_launch_file_runs_as_the_session_did(workspace, make_node, caller,
                                                                                  counting, monkeypatch, tmp_path):
    from ipyros.ros2 import launchfile, nodes

    installed = workspace / "install" / "keeper_pkg"
    monkeypatch.setenv("AMENT_PREFIX_PATH", os.pathsep.join([str(installed), os.environ["AMENT_PREFIX_PATH"]]))
    config = installed / "share" / "keeper_pkg" / "config" / "keeper.yaml"
    config.write_text(config.read_text().replace("volume: 11", "volume: 12"))  # the params file is what it reads
    launched = launchfile.read(installed / "share" / "keeper_pkg" / "launch" / "keeper.launch.xml")
    assert [b.launch_node for b in launched.nodes] == ["/kp/keeper", "/kp/echo_node"], launched.notes
    poisoned = tmp_path / "no_ipyros" / "ipyros"
    poisoned.mkdir(parents=True)
    (poisoned / "__init__.py").write_text('raise ImportError("an exported node runs without ipyros")\n')
    site = next((installed / "lib").glob("python3*/site-packages"))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(poisoned.parent), str(site)]), "PYTHONUNBUFFERED": "1"}
    procs = []
    heard: dict[str, list] = {"loud": [], "beat": [], "cmd": []}
    sensors = Sensors(None, "/kp/scan")
    try:
        for base in launched.nodes:
            log = (tmp_path / f"{base.executable}.log").open("w")
            procs.append((subprocess.Popen(nodes.command(base), env=env, stdout=log, stderr=subprocess.STDOUT,
                                           start_new_session=True), tmp_path / f"{base.executable}.log"))
        probe = make_node("kp_probe")
        probe.new.publish("/kp/in", msgType=String)
        for topic, cls in (("loud", String), ("beat", String), ("cmd", Twist)):
            probe.new.subscribe(f"/kp/{topic}", handler=heard[topic].append, msgType=cls)
        probe.new.publish("/kp/scan", msgType=LaserScan)
        probe.create()
        sensors.node = probe
        sensors.start()
        wait_for(lambda: probe.write("/kp/in", String(data="hi")) or "v1 echo> hi" in [m.data for m in heard["loud"]],
                 timeout=30, interval=0.2, what="the installed node's handler on its basenode's output")
        wait_for(lambda: "beat 12" in [m.data for m in heard["beat"]], timeout=10,
                 what="the timer's beat with the parameter from the package's params file")
        wait_for(lambda: 0.5 in [m.linear.x for m in heard["cmd"]], timeout=10, what="the guarded cmd")
        assert {m.linear.x for m in heard["cmd"]} <= {0.0, 0.5}, "the guard's limit held in the installed node"
        sensors.ranges = [0.3]  # the guard's rule: an obstacle, the stop message, as in the session

        def stopped() -> bool:  # half a second of the guarded cmd, nothing but the stop message in it
            heard["cmd"].clear()
            time.sleep(0.5)
            return {m.linear.x for m in heard["cmd"]} == {0.0}

        wait_for(stopped, timeout=10, what="the stop message near an obstacle, by the rule exported with the guard")
        sensors.stop()
        answer = caller("/kp/check", SetBool, SetBool.Request(data=True))
        assert answer.success and answer.message == "echo>  checked"
        assert counting.plain_send("/kp/count", 3) == ("succeeded", 3, [1, 2, 3])  # the action it serves
        probe.shutdown()
    except BaseException:
        for _, log in procs:
            print(log.name, log.read_text()[-2000:])
        raise
    finally:
        sensors.stop()
        for proc, _ in procs:
            os.killpg(proc.pid, signal.SIGINT)
        for proc, _ in procs:
            try:
                proc.wait(15)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
