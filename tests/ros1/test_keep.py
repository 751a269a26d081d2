"""Keeping the work: save and load round trips, load errors, and exported scripts run for real.

The handlers are module-level functions, so ``inspect.getsource`` finds them as it finds a
function typed at the prompt. They call ``nd.write``/``wnode.write``: load binds those names
to the loaded node, export to the script's stand-in object.
"""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import threading
from contextlib import contextmanager
from pathlib import Path

import pytest
import yaml
from geometry_msgs.msg import Pose, Twist
from ros1_fixtures import ROS1_PYTHON, master_state, wait_for
from std_msgs.msg import String
from std_srvs.srv import Empty, EmptyResponse

from ipyros import rosNode
from ipyros.core.errors import IpyrosError
from ipyros.files import export, modelfile as keep
from ipyros.ros1 import params as param_server, services

speed = 2.5  # read by showPose when called: exported as a literal


def showPose(data):  # noqa: N802 - the paper's name
    cmd = Twist()
    cmd.linear.x = speed * data.position.x
    cmd.angular.z = math.atan2(data.position.y, data.position.x)
    nd.write("/turtle1/cmd_vel", cmd)  # noqa: F821 - bound by load / export


def heartbeat():
    nd.write("~alive", String("alive"))  # noqa: F821


def reset(request):
    return EmptyResponse()


def shout(msg):
    wnode.write("loud", String(msg.data.upper()))  # noqa: F821


LIMIT = 3


def clamp(value):  # a helper of a handler: exported with it
    return min(value, LIMIT)


def turtle_node(make_node):
    """The paper's turtle node, with a timer, a service and a parameter."""
    nd = make_node("turtle_control_node")
    (nd.new.subscribe(topic="/turtle1/pose", handler=showPose, msgType=Pose)
           .publish(topic="/turtle1/cmd_vel", msgType=Twist)
           .publish(topic="~alive", msgType=String)
           .service("~reset", srvType=Empty, handler=reset))
    nd.timer(0.1, heartbeat)
    nd.params["gain"] = 1.5
    return nd


def wrapper_node(make_node):
    """echo_node wrapped: `in` relayed unchanged, its `out` intercepted by shout, its ~reset relayed."""
    wnode = make_node("keep_wrapper", namespace="/keep_ns")
    wnode.baseNode("echo_node", args=["--prefix", "echo> "], params={"exit_after": 0}).basePackage("ipyros_test_nodes")
    wnode.reuse.subscribe("in", type=String).publish("out", type=String).service("~reset", type=Empty)
    wnode.new.subscribe("out", handler=shout, type=String).publish("loud", type=String)
    wnode.timer(1.0, lambda event: None, name="idle")
    wnode.params["volume"] = 11
    return wnode


def world(make_node, name, publish, *listen):
    """A DSL node in this process around the node under test: publishes ``publish`` (topic, type),
    and collects what arrives on each ``listen`` (topic, type) in ``heard[topic]``."""
    node = make_node(name)
    node.new.publish(*publish)
    heard: dict[str, list] = {}
    for topic, type_ in listen:
        node.new.subscribe(topic, handler=heard.setdefault(topic, []).append, msgType=type_)
    return node.create(), heard


# -- save and load --------------------------------------------------------------------------

def test_plain_node_round_trip(make_node, tmp_path):
    nd = turtle_node(make_node)
    path = nd.save(tmp_path / "turtle.yaml")
    text = path.read_text()
    data = yaml.safe_load(text)
    assert data[keep.FORMAT_KEY] == keep.FORMAT and data["node"] == nd.model().to_dict()
    assert "source: |\n    def showPose(data):" in text  # a literal block: readable, diffs by line
    pose = next(h for h in data["handlers"] if h["name"] == "showPose")
    assert pose["imports"] == ["from geometry_msgs.msg import Twist", "import math"]
    assert [h["slot"] for h in data["handlers"]] == ["topic /turtle1/pose", "timer heartbeat",
                                                     "service /turtle_control_node/reset"]

    namespace: dict = {}
    loaded = rosNode.load(path, namespace, trust=True)
    assert not loaded.created and loaded.model() == nd.model()
    assert loaded.handler("/turtle1/pose") is namespace["showPose"] is not showPose
    assert namespace["nd"] is loaded  # the name its handlers write with
    assert loaded.save(tmp_path / "again.yaml").read_text() == text  # the loaded sources are findable too


def test_the_model_as_json_round_trips(make_node, tmp_path):
    nd = turtle_node(make_node)
    path = nd.save(tmp_path / "turtle.json")
    data = json.loads(path.read_text())
    assert data[keep.FORMAT_KEY] == keep.FORMAT and data["node"] == nd.model().to_dict()
    assert rosNode.load(path, {}, trust=True).model() == nd.model()


def test_a_model_without_handler_sources_takes_them_by_name(make_node, tmp_path):
    nd = turtle_node(make_node)
    data = {keep.FORMAT_KEY: keep.FORMAT, "node": nd.model().to_dict()}  # what a model tool would write
    path = tmp_path / "model.json"
    path.write_text(json.dumps(data))
    with pytest.raises(IpyrosError, match=r"no source for handler\(s\) heartbeat, reset, showPose and they are "
                                          r"not defined here"):
        rosNode.load(path, {})
    namespace = {"showPose": showPose, "heartbeat": heartbeat, "reset": reset}
    loaded = rosNode.load(path, namespace)
    assert loaded.model() == nd.model() and loaded.handler("/turtle1/pose") is showPose


def test_wrapping_node_round_trip(make_node, tmp_path):
    wnode = wrapper_node(make_node)
    loaded = rosNode.load(wnode.save(tmp_path / "wrapper.yaml"), trust=True)
    assert loaded.model() == wnode.model()
    assert loaded.model().base.args == ["--prefix", "echo> "] and loaded.params["volume"] == 11


def test_loaded_node_runs_its_handlers_in_the_namespace_given(make_node, tmp_path):
    path = turtle_node(make_node).save(tmp_path / "turtle.yaml")
    namespace = {"speed": 4.0}
    loaded = rosNode.load(path, namespace, trust=True)
    try:
        loaded.create()
        driver, heard = world(make_node, "keep_turtle_world", ("/turtle1/pose", Pose), ("/turtle1/cmd_vel", Twist))
        velocities = heard["/turtle1/cmd_vel"]
        pose = Pose()
        pose.position.x = 2.0
        wait_for(lambda: driver.write("/turtle1/pose", pose) or velocities, timeout=20, what="a velocity from showPose")
        assert velocities[-1].linear.x == 8.0  # speed from the namespace, not this module's 2.5
    finally:
        loaded.shutdown()


def test_lambda_handlers(make_node, tmp_path):
    nd = make_node("keep_lambdas")
    nd.new.subscribe("/keep/a", handler=lambda m: got.append(m.data), msgType=String)  # noqa: F821
    path = nd.save(tmp_path / "lambdas.yaml")
    assert yaml.safe_load(path.read_text())["handlers"][0]["source"] == "lambda m: got.append(m.data)\n"
    namespace = {"got": []}
    loaded = rosNode.load(path, namespace, trust=True)
    loaded.handler("/keep/a")(String("x"))
    assert namespace["got"] == ["x"] and loaded.model() == nd.model()

    nd.new.subscribe("/keep/a",  # getsource gives only the lambda's line of this statement
                     handler=lambda msg: got.append(msg.data.upper()),  # noqa: F821
                     msgType=String)
    handler = yaml.safe_load(nd.save(path).read_text())["handlers"][0]
    assert handler["source"] == "lambda msg: got.append(msg.data.upper())\n"

    nd.new.subscribe("/keep/b", handler=[lambda m: 1, lambda m: 2][1], msgType=String)
    with pytest.raises(IpyrosError, match=r"/keep/b is a lambda that looks like other lambdas on its line; define it with def"):
        nd.save(tmp_path / "two.yaml")
    nd.new.subscribe("/keep/b", handler=[].append, msgType=String)
    with pytest.raises(IpyrosError, match=r"/keep/b is builtin_function_or_method 'append', which has no source to keep; define it with def"):
        nd.save(tmp_path / "builtin.yaml")


def test_handler_typed_at_an_ipython_prompt(make_node, tmp_path):
    from shell import interactive_shell, ok

    with interactive_shell(load=False) as shell:
        ok(shell, "def onChatter(msg):\n    print('heard', msg.data)\n")
        nd = make_node("keep_prompt")
        nd.new.subscribe("/keep/chatter", handler=shell.user_ns["onChatter"], msgType=String)
        path = nd.save(tmp_path / "prompt.yaml")
        assert "def onChatter(msg):\n        print('heard', msg.data)" in path.read_text()
        rosNode.load(path, shell.user_ns, trust=True)
        assert shell.user_ns["onChatter"] is not nd.handler("/keep/chatter")  # rebound by the load


@pytest.mark.parametrize("change, message", [
    (None, r"cannot read .*missing\.yaml: No such file"),
    ("node: [unclosed", r"is not valid YAML at line 1"),
    ("- just a list", r"is not a saved ipyros node"),
    ("ipyros_node_format: 99\nnode: {}\nhandlers: []", r"format version 99, this ipyros reads version 1"),
    ("ipyros_node_format: 1\nhandlers: []", r"missing or malformed key 'node'"),
    ("ipyros_node_format: 1\nnode: {name: x, colour: red}\nhandlers: []", r"malformed: unknown NodeModel field.*colour"),
])
def test_load_errors_say_what_is_wrong(tmp_path, change, message):
    path = tmp_path / "missing.yaml"
    if change is not None:
        path.write_text(change)
    with pytest.raises(IpyrosError, match=message) as error:
        rosNode.load(path)
    assert "\n" not in str(error.value)


def test_load_names_a_handler_that_does_not_compile(make_node, tmp_path):
    path = turtle_node(make_node).save(tmp_path / "turtle.yaml")
    path.write_text(path.read_text().replace("def heartbeat():", "def heartbeat() oops:"))
    with pytest.raises(IpyrosError, match=r"handler heartbeat \(timer heartbeat\) does not compile: .* line 1"):
        rosNode.load(path, trust=True)


def test_a_model_file_carrying_code_is_not_run_unless_trusted(make_node, tmp_path):
    path = turtle_node(make_node).save(tmp_path / "turtle.yaml")
    planted = tmp_path / "planted"
    data = yaml.safe_load(path.read_text())
    data["handlers"][0]["imports"] = [f"import os; open({str(planted)!r}, 'w').close()"]
    path.write_text(yaml.safe_dump(data))
    namespace: dict = {}
    with pytest.raises(IpyrosError) as error:
        rosNode.load(path, namespace)
    text = str(error.value)
    assert text.startswith(f"{path} would run imports ") and "import os; open(" in text \
        and "the handlers showPose, heartbeat, reset; read it, and if you trust it load it with trust=True" in text
    assert not planted.exists() and not namespace, "nothing ran"
    rosNode.load(path, namespace, trust=True)
    assert planted.exists()


# -- export ----------------------------------------------------------------------------------

@contextmanager
def running(script: Path):
    """Run an exported script with the Python it names; yield (process, output lines); stop it after."""
    proc = subprocess.Popen([ROS1_PYTHON, str(script)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.extend(line.rstrip("\n") for line in proc.stdout), daemon=True)
    reader.start()
    try:
        yield proc, lines
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(20)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        reader.join(5)


def stop(proc: subprocess.Popen) -> int:
    proc.send_signal(signal.SIGINT)  # Ctrl-C, as a user would stop it
    return proc.wait(20)


def test_exported_turtle_node_runs_without_ipyros(make_node, tmp_path, ros_master):
    script = turtle_node(make_node).export(tmp_path / "turtle_control_node.py")
    text = script.read_text()
    assert text.startswith(f"#!{ROS1_PYTHON}\n") and os.access(script, os.X_OK)
    for line in ("import math", "from geometry_msgs.msg import Pose, Twist", "speed = 2.5", "nd = NodeHandle()",
                 "def showPose(data):", "rospy.init_node('turtle_control_node')",
                 "rospy.Timer(rospy.Duration(0.1), lambda event: heartbeat())"):
        assert line in text
    driver, heard = world(make_node, "keep_export_world", ("/turtle1/pose", Pose), ("/turtle1/cmd_vel", Twist),
                          ("/turtle_control_node/alive", String))
    velocities, alive = heard["/turtle1/cmd_vel"], heard["/turtle_control_node/alive"]
    pose = Pose()
    pose.position.x = 2.0
    with running(script) as (proc, lines):
        wait_for(lambda: driver.write("/turtle1/pose", pose) or velocities, timeout=30,
                 what=f"a velocity from the exported showPose (output: {lines[-5:]})")
        assert velocities[-1].linear.x == 5.0  # 2.5 * 2.0
        wait_for(lambda: alive, timeout=10, what="the exported heartbeat timer")
        assert alive[-1].data == "alive"
        state = master_state(ros_master)
        assert "/turtle_control_node" in state["srv"]["/turtle_control_node/reset"]
        assert wait_for(lambda: param_server.get_param("/turtle_control_node/gain", None), what="~gain") == 1.5
        assert stop(proc) == 0


def test_exported_wrapper_runs_and_stops_its_basenode(make_node, tmp_path, ros_master):
    script = wrapper_node(make_node).export(tmp_path / "keep_wrapper.py")
    text = script.read_text()
    assert "os.environ[\"ROS_NAMESPACE\"] = '/keep_ns/'" in text
    assert "relay('/keep_ns/in', '/keep_ns/keep_wrapper/base/keep_ns/in', String)" in text
    assert "rospy.Timer(rospy.Duration(1.0), timer_idle)" in text
    assert "'_exit_after:=0'" in text and "'/keep_ns/out:=/keep_ns/keep_wrapper/base/keep_ns/out'" in text
    driver, heard = world(make_node, "keep_wrapper_world", ("/keep_ns/in", String), ("/keep_ns/loud", String),
                          ("/keep_ns/out", String))
    loud, out = heard["/keep_ns/loud"], heard["/keep_ns/out"]
    with running(script) as (proc, lines):
        started = wait_for(lambda: next((line for line in lines if line.startswith("started basenode")), None),
                           timeout=20, what="the basenode to start")
        base_pid = int(started.rsplit("pid ", 1)[1].rstrip(")"))
        wait_for(lambda: driver.write("/keep_ns/in", String("hi")) or loud, timeout=30,
                 what=f"echo_node's answer through shout (output: {lines[-5:]})")
        assert loud[-1].data == "ECHO> HI" and out == []  # intercepted: echo_node's out goes to shout only
        service = services.service_proxy("/keep_ns/echo_node/reset", Empty)
        service.wait_for_service(10)
        service()  # answered by echo_node, through the script's service relay
        wait_for(lambda: "reset" in lines, timeout=10, what="echo_node to print reset")
        assert stop(proc) == 0
        wait_for(lambda: not Path(f"/proc/{base_pid}").exists(), timeout=10, what="the basenode to be gone")
        assert "echo_node shut down" in lines  # stopped by Ctrl-C, so it unregistered
    assert param_server.get_param("/keep_ns/keep_wrapper/volume") == 11
    assert "/keep_ns/echo_node" not in str(master_state(ros_master))


def test_export_marks_globals_it_cannot_write(make_node, tmp_path):
    nd = make_node("keep_unset")
    threshold = threading.Event()  # not a literal: the script cannot recreate it

    def watch(msg):
        if threshold.is_set():
            print(clamp(len(msg.data)))

    nd.new.subscribe("/keep/watch", handler=watch, msgType=String)
    with pytest.warns(export.ExportWarning, match="needs values for threshold"):
        script = nd.export(tmp_path / "watch.py")
    text = script.read_text()
    assert "threshold = None  # set me: used by handler watch" in text
    assert "def clamp(value):" in text and "LIMIT = 3" in text
    compile(text, str(script), "exec")


def test_the_dsl_methods_save_load_and_export(make_node, tmp_path, ros_session):
    from ipyros import rosNode

    nd = turtle_node(make_node)
    saved = nd.save(tmp_path / "nd.yaml")
    again = rosNode.load(saved, {}, session=ros_session, trust=True)
    assert again.model() == nd.model()
    assert nd.export(tmp_path / "nd.py").read_text().startswith(f"#!{ROS1_PYTHON}")
