"""Keeping the work on ROS 2, in fresh interpreters: build and change a wrapping node, save it, restore it
elsewhere and see the same live behaviour; export it as an rclpy script that runs with ipyros not importable.

The first interpreter builds a wrapping node (echo_node.py as basenode: its ``in`` relayed, its ``out``
intercepted by a handler that uses a helper and a global, its service relayed, a timer reading a parameter),
changes the handler once, saves the session as Python and exports the node, then exits. The saved file
and the exported script each run in a process of their own; this process checks what they do through ROS 2.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from ros2_fixtures import wait_for
from std_msgs.msg import String
from std_srvs.srv import SetBool

ECHO_NODE = Path(__file__).resolve().parent / "peers" / "echo_node.py"
NS = "/k2"

BUILD = f'''
import sys
from ipyros import rosNode
from ipyros.dsl import save_session
from std_msgs.msg import String
from std_srvs.srv import SetBool
mark = "*"
def shout(msg):
    nd.write("loud", String(data="v1 " + msg.data))
def beat():
    nd.write("beat", String(data="beat " + str(nd.params["volume"])))
nd = rosNode("keeper", namespace="{NS}")
nd.baseNode("{ECHO_NODE}", params={{"prefix": "echo> "}})
nd.reuse.subscribe("in", type=String).publish("out", type=String).service("check", type=SetBool)
nd.new.subscribe("out", handler=shout, type=String).publish("loud", type=String).publish("beat", type=String)
nd.timer(0.2, beat)
nd.params["volume"] = 11
nd.create()
def decorate(text):
    return mark + text + mark
def shout(msg):
    nd.write("loud", String(data="v2 " + decorate(msg.data)))
nd.new.subscribe("out", handler=shout, type=String)
save_session(sys.argv[1], globals())
nd.export(sys.argv[2], globals())
print("saved", flush=True)
nd.shutdown()
'''

#: Runs a script as ``python script`` would, with ipyros not importable.
WITHOUT_IPYROS = "import runpy, sys; sys.modules['ipyros'] = None; sys.argv = sys.argv[1:]; runpy.run_path(sys.argv[0], run_name='__main__')"


@pytest.fixture
def saved(tmp_path):
    """The saved session and the exported script, made by a first interpreter that has exited."""
    build = tmp_path / "build.py"
    build.write_text(BUILD)
    paths = tmp_path / "saved_session.py", tmp_path / "keeper_node.py"
    done = subprocess.run([sys.executable, str(build), *map(str, paths)], capture_output=True, text=True, timeout=90)
    assert done.returncode == 0 and "saved" in done.stdout, done.stderr[-2000:]
    return paths


def live_checks(make_node, caller) -> None:
    """What the restored node and the exported script must both do: the v2 handler on the basenode's
    output, the timer with the parameter, the basenode's service relayed."""
    heard: dict[str, list[str]] = {"loud": [], "beat": []}
    probe = make_node("k2_probe")
    probe.new.publish(f"{NS}/in", msgType=String)
    for topic in heard:
        probe.new.subscribe(f"{NS}/{topic}", handler=lambda m, t=topic: heard[t].append(m.data), msgType=String)
    probe.create()
    wait_for(lambda: probe.write(f"{NS}/in", String(data="hi")) or "v2 *echo> hi*" in heard["loud"], timeout=30,
             interval=0.2, what="the v2 handler's answer on /k2/loud")
    wait_for(lambda: "beat 11" in heard["beat"], timeout=10, what="the timer's beat with the parameter")
    answer = caller(f"{NS}/check", SetBool, SetBool.Request(data=True))
    assert answer.success and answer.message == "echo>  checked"
    probe.shutdown()


def run_until_checked(argv: list[str], tmp_path: Path, name: str, check) -> None:
    with open(tmp_path / f"{name}.log", "w") as log:
        proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT,
                                start_new_session=True)
    try:
        check()
    except BaseException:
        print((tmp_path / f"{name}.log").read_text()[-3000:])
        raise
    finally:
        os.killpg(proc.pid, 2)  # Ctrl-C: the node stops its basenode
        try:
            proc.wait(15)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, 9)
            proc.wait()


def test_saved_on_ros2_restored_in_a_fresh_interpreter_works_the_same(saved, make_node, caller, tmp_path):
    session_file, _ = saved
    assert "Made on ROS 2." in session_file.read_text()
    run_until_checked([sys.executable, str(session_file)], tmp_path, "restored",
                      lambda: live_checks(make_node, caller))


def test_exported_rclpy_script_runs_without_ipyros(saved, make_node, caller, tmp_path):
    _, script = saved
    text = script.read_text()
    assert "import rclpy" in text and "import ipyros" not in text and "from ipyros" not in text
    run_until_checked([sys.executable, "-c", WITHOUT_IPYROS, str(script)], tmp_path, "exported",
                      lambda: live_checks(make_node, caller))


# A model file as a ROS 1 session writes it (nd.save("turtle.yaml")): types as pkg/Type, no QoS.
ROS1_MODEL = """\
ipyros_node_format: 1
ros: ROS 1
node:
  name: from_ros1
  namespace: /
  base: null
  topics:
  - {name: /x2/cmd, resolved: /x2/cmd, direction: publish, type: geometry_msgs/Twist, role: new, handler: null, latch: false}
  - {name: /x2/scan, resolved: /x2/scan, direction: subscribe, type: std_msgs/String, role: new, handler: on_scan, latch: false}
  timers: []
  services: []
  params: {gain: 2.5}
handlers:
- slot: topic /x2/scan
  name: on_scan
  source: |
    def on_scan(msg):
        heard.append(msg.data)
"""


def test_a_model_made_on_ros1_loads_on_ros2_and_says_so(tmp_path, ros2_session, notices, make_node):
    from ipyros import rosNode
    from ipyros.core import errors

    path = tmp_path / "from_ros1.yaml"
    path.write_text(ROS1_MODEL)
    heard: list[str] = []
    node = rosNode.load(str(path), {"heard": heard}, trust=True)
    try:
        assert notices == [f"ipyros: {path} was made on ROS 1; loading it on ROS 2"]
        node.create()
        assert node.params["gain"] == 2.5
        talker = make_node("x2_talker")
        talker.new.publish("/x2/scan", msgType=String).create()
        wait_for(lambda: talker.write("/x2/scan", String(data="s")) or heard, timeout=10, interval=0.1,
                 what="the loaded handler to hear the topic")
    finally:
        node.shutdown()
    ros1_launch = tmp_path / "robot.launch"  # roslaunch's XML: ROS 2 names the executable exec=, not type=
    ros1_launch.write_text('<launch><node pkg="ipyros_demo" type="turtle_sim" name="turtle_sim"/></launch>')
    launch = tmp_path / "launched.yaml"
    launch.write_text(ROS1_MODEL.replace("base: null", "base: {executable: turtle_sim, package: ipyros_demo, "
                                                      f"launch: {ros1_launch}, launch_node: /turtle_sim}}"))
    with pytest.raises(errors.IpyrosError, match="launched.yaml: robot.launch: a <node> without exec=... "
                                                 r"\(that is ROS 1's spelling: ROS 2 names it exec=\)"):
        rosNode.load(str(launch), {"heard": heard}, trust=True)
