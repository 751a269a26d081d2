"""Wrapping a running ROS 2 node: launched remapped onto the wrapper, relayed, intercepted, live."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import pytest
from ros2_fixtures import wait_for
from std_msgs.msg import String

from ipyros.core.errors import MessageTypeError
from ipyros.dsl import engine_of

ECHO_NODE = str(Path(__file__).resolve().parent / "peers" / "echo_node.py")


def listen(make_node, name, topic):
    seen: list[str] = []
    make_node(name).new.subscribe(topic, handler=lambda m: seen.append(m.data), msgType=String).create()
    return seen


def test_wrapping_a_python_basenode_in_a_namespace(make_node, failures):
    out = listen(make_node, "w2_listener", "/robot2/out")
    shouted = listen(make_node, "w2_shout_listener", "/robot2/shouted")
    feeder = make_node("w2_feeder").new.publish("/robot2/in", msgType=String).create()
    send = lambda text: feeder.write("/robot2/in", String(data=text))  # noqa: E731

    w = make_node("w2")
    w.baseNode(ECHO_NODE, namespace="robot2", params={"prefix": "B:"})
    w.reuse.subscribe("in", type=String).publish("out", type=String)
    assert w.fullname == "/robot2/w2"
    w.create()
    assert w.base.running and "--ros-args" in w.base.argv
    wait_for(lambda: any("echo_node ready" in line for line in w.base.tail()), what="the basenode's log")
    # Relayed both ways through the wrapper: in → basenode → out.
    wait_for(lambda: send("a") or "B:a" in out, timeout=20, interval=0.1, what="a message through the wrap")

    # Intercept its output live with a handler that writes a new topic.
    w.new.publish("/robot2/shouted", msgType=String)
    w.new.subscribe("out", handler=lambda m: w.write("/robot2/shouted", String(data=m.data.upper())), msgType=String)
    wait_for(lambda: send("b") or "B:B" in shouted, timeout=20, interval=0.1, what="the intercepting handler")
    count = len(out)
    wait_for(lambda: send("c") or "B:C" in shouted, timeout=20, interval=0.1, what="more through the handler")
    assert len(out) == count, "while intercepted, the basenode's output does not reach /robot2/out"

    # Give it back: the relay serves /robot2/out again.
    w.new.unsubscribe("out")
    wait_for(lambda: send("d") or "B:d" in out, timeout=20, interval=0.1, what="the relay back")
    pid = w.base.pid
    w.shutdown()
    assert w.base is None and not Path(f"/proc/{pid}").exists() or _zombie(pid)
    assert failures == []


def _zombie(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] == "Z"
    except OSError:
        return True


def test_a_latched_output_stays_latched_through_the_wrapper(make_node):
    """The basenode says "up" once, transient-local; a subscriber that comes later still gets it, from the relay."""
    import time

    from rclpy.qos import DurabilityPolicy, QoSProfile

    w = make_node("w2_latch")
    w.baseNode(ECHO_NODE, namespace="robot6", params={"prefix": "L"})
    w.reuse.publish("status", type=String)
    w.create()
    wait_for(lambda: engine_of(w).sent() and engine_of(w).sent()[0].messages >= 1, timeout=20,
             what="the relay to forward the status")
    time.sleep(0.5)  # the subscriber below comes after the message went by: only latching brings it
    late: list[str] = []
    listener = make_node("w2_late_listener").create()
    graph_node = engine_of(listener).session.process.host(listener.fullname)
    graph_node.create_subscription(String, "/robot6/status", lambda m: late.append(m.data),
                                   QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    wait_for(lambda: late == ["L up"], timeout=10, what="the latched status for a late subscriber")


def test_a_basenode_service_relayed_then_intercepted(make_node, caller):
    from std_srvs.srv import SetBool

    w = make_node("w2_srv")
    w.baseNode(ECHO_NODE, namespace="robot5", params={"prefix": "S"})
    w.reuse.service("check", type=SetBool)
    w.create()
    answer = caller("/robot5/check", SetBool, SetBool.Request(data=True))
    assert answer.success is True and answer.message == "S checked", "the basenode answers through the wrapper"
    w.new.service("check", SetBool, handler=lambda request: SetBool.Response(success=False, message="mine"))
    assert caller("/robot5/check", SetBool, SetBool.Request(data=True)).message == "mine"
    w.remove(service="check")
    w.reuse.service("check", type=SetBool)  # given back to the basenode
    assert caller("/robot5/check", SetBool, SetBool.Request(data=True)).message == "S checked"


def test_a_slow_basenode_service_stalls_nothing_else(make_node, caller):
    """A relayed call waits for the basenode off the executor thread: the session's subscriptions go on meanwhile."""
    from std_srvs.srv import SetBool

    w = make_node("w2_slow")
    w.baseNode(ECHO_NODE, namespace="robot7", params={"prefix": "Z", "check_delay": 6.0})
    w.reuse.service("check", type=SetBool)
    w.create()
    heard = listen(make_node, "w2_slow_listener", "/robot7/tick")
    talker = make_node("w2_slow_talker").new.publish("/robot7/tick", msgType=String).create()
    wait_for(lambda: talker.write("/robot7/tick", String(data="before")) or heard, timeout=20, interval=0.2,
             what="the listener")
    answers: list = []
    calling = threading.Thread(target=lambda: answers.append(
        caller("/robot7/check", SetBool, SetBool.Request(data=True), patience=30)))
    calling.start()
    try:
        wait_for(lambda: "checking" in w.base.tail(), timeout=20, what="the basenode to take the call")
        talker.write("/robot7/tick", String(data="during"))
        wait_for(lambda: "during" in heard, timeout=4, what="a message while the basenode's service is busy")
        assert not answers
    finally:
        calling.join(timeout=60)
    assert answers and answers[0].message == "Z checked"


def test_discovery_reads_the_basenode_from_the_ros2_graph(make_node):
    w = make_node("w2_discovered")
    w.baseNode(ECHO_NODE, namespace="robot3")
    interface = w.discover()
    assert interface.node == "/robot3/echo_node"
    assert ("/robot3/out", "std_msgs/String") in interface.publications
    assert ("/robot3/in", "std_msgs/String") in interface.subscriptions
    assert "/rosout (publishes)" in interface.left_out
    assert ("/robot3/check", "std_srvs/SetBool") in interface.services
    assert [(t.name, t.direction, t.role) for t in w.model().topics] == [
        ("out", "publish", "reuse"), ("status", "publish", "reuse"), ("in", "subscribe", "reuse")]


def test_discovery_declares_all_it_can_and_names_the_types_to_install(make_node, notices, monkeypatch):
    """A basenode with a type this Python lacks (a workspace's own, a package not installed): discover() declares
    the rest and says in one line what was left and how to install it (issue 24)."""
    import sys

    from ipyros.core import msgtypes

    w = make_node("w2_custom")
    w.baseNode(str(Path(ECHO_NODE).with_name("custom_types.py")), namespace="robot_custom")
    monkeypatch.setitem(sys.modules, "test_msgs", None)  # as a venv without the package: the import fails
    monkeypatch.setitem(sys.modules, "test_msgs.msg", None)
    interface = w.discover()
    assert [(t.name, t.direction) for t in w.model().topics] == [("plain", "publish"), ("plain_in", "subscribe")]
    assert interface.not_installed == ["/robot_custom/odd (test_msgs/Builtins)"]
    said = [n for n in notices if "not declared" in n]
    assert said == [f"ipyros: not declared, their types are not installed here: /robot_custom/odd "
                    f"(test_msgs/Builtins): {msgtypes.install_hint('test_msgs')}; the rest of "
                    "/robot_custom/custom_types is declared"], notices


def test_a_basenode_by_package_is_found_in_the_ament_index(make_node, tmp_path, monkeypatch):
    """An installed package, as colcon lays one out: a marker in the resource index, executables in lib/."""
    import os
    import shutil
    import sys

    from ipyros.core import errors

    prefix = tmp_path / "install"
    (prefix / "share" / "ament_index" / "resource_index" / "packages").mkdir(parents=True)
    (prefix / "share" / "ament_index" / "resource_index" / "packages" / "echo_pkg").touch()
    (prefix / "lib" / "echo_pkg").mkdir(parents=True)
    node = prefix / "lib" / "echo_pkg" / "echo_node"
    node.write_text(f"#!{sys.executable}\n" + Path(ECHO_NODE).read_text())
    node.chmod(0o755)
    monkeypatch.setenv("AMENT_PREFIX_PATH", os.pathsep.join([str(prefix), sys.prefix]))

    with pytest.raises(errors.BaseNodeError, match="package 'echo_pkg' has no executable 'echo_nod'; did you mean "
                                                  "echo_node\\? its executables: echo_node"):
        make_node("w2_typo").baseNode("echo_nod").basePackage("echo_pkg").create()
    with pytest.raises(errors.BaseNodeError, match="unknown ROS 2 package 'echo_pk': did you mean echo_pkg\\?"):
        make_node("w2_typo2").baseNode("echo_node").basePackage("echo_pk").create()

    out = listen(make_node, "w2_pkg_listener", "/robot4/out")
    feeder = make_node("w2_pkg_feeder").new.publish("/robot4/in", msgType=String).create()
    w = make_node("w2_pkg")
    w.baseNode("echo_node", namespace="robot4").basePackage("echo_pkg")
    w.reuse.subscribe("in", type=String).publish("out", type=String)
    w.create()
    assert w.base.argv[:2] == [sys.executable, str(node)]  # a Python script runs with ipyros's own Python
    wait_for(lambda: feeder.write("/robot4/in", String(data="p")) or "echo:p" in out, timeout=20, interval=0.1,
             what="a message through the packaged basenode")
    w.shutdown()
    shutil.rmtree(prefix)


def test_the_basenode_lifecycle_log_restart_crash_and_no_orphan(make_node, ros2_session):
    told: list[str] = []
    previous, ros2_session.notice = ros2_session.notice, told.append
    try:
        feeder = make_node("w2_life_feeder").new.publish("/robot7/in", msgType=String).create()
        w = make_node("w2_life")
        w.baseNode(ECHO_NODE, namespace="robot7")
        w.reuse.subscribe("in", type=String)
        w.create()
        wait_for(lambda: any("echo_node ready" in line for line in w.base.tail()), what="the basenode's log")
        first = w.base.pid
        w.base.restart()
        assert w.base.pid != first and _gone(first)
        wait_for(lambda: w.base.running and any("echo_node ready" in line for line in w.base.tail()),
                 what="the restarted basenode")
        # (on a loaded machine the session may first say that the restarted basenode is not in the graph yet)
        crash = wait_for(lambda: feeder.write("/robot7/in", String(data="crash")) or
                         next((text for text in told if "exited" in text), None),
                         timeout=20, interval=0.2, what=f"the crash to be reported (told: {told})")
        assert "basenode /robot7/echo_node of w2_life exited with code 3; restart it with w2_life.base.restart()" \
            in crash and "asked to crash" in crash
        w.base.restart()  # and it runs again
        wait_for(lambda: w.base.running, what="the basenode after the crash")
        pid = w.base.pid
        w.shutdown()
        assert _gone(pid), "shutdown stops the basenode"
    finally:
        ros2_session.notice = previous


def _gone(pid: int) -> bool:
    return wait_for(lambda: not Path(f"/proc/{pid}").exists() or _zombie(pid), timeout=10, what=f"pid {pid} to end")


_INTERPRETER = """
import sys
from ipyros import rosNode
from std_msgs.msg import String
w = rosNode("orphan_wrapper")
w.baseNode(sys.argv[2], namespace="orphans")
w.reuse.publish("out", type=String)
w.create()
print("BASE", w.base.pid, flush=True)
if sys.argv[1] == "wait":
    sys.stdin.read()
"""


@pytest.mark.parametrize("ending", ["exit", "SIGKILL"])
def test_no_orphan_basenode_when_the_interpreter_exits_or_is_killed(ending):
    """The basenode dies with the interpreter that wrapped it, even one killed without a chance to clean up."""
    import signal
    import subprocess
    import sys

    import tempfile

    for attempt in range(2):  # a create() that failed on a loaded machine is not what this tests: once more, said
        errors = tempfile.TemporaryFile("w+")
        proc = subprocess.Popen([sys.executable, "-c", _INTERPRETER, "exit" if ending == "exit" else "wait",
                                 ECHO_NODE], stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=errors, text=True)
        line = proc.stdout.readline()
        if line.startswith("BASE") or attempt == 1:
            break
        proc.wait(30)
        errors.seek(0)
        print("the wrapping interpreter did not start its basenode; again:", errors.read()[-2000:])
    try:
        errors.seek(0)
        assert line.startswith("BASE"), errors.read()[-2000:]
        base_pid = int(line.split()[1])
        if ending == "SIGKILL":
            assert not _zombie(base_pid)
            proc.send_signal(signal.SIGKILL)
        assert proc.wait(30) in (0, -signal.SIGKILL)
        _gone(base_pid)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


@pytest.mark.parametrize("typed_first", [True, False], ids=["typed-then-relay", "relay-then-typed"])
def test_a_relay_and_a_typed_subscriber_on_one_topic_each_get_what_they_asked_for(make_node, failures,
                                                                                   typed_first):
    """A reuse relay (bytes) and a handler (a message) on one topic, in either order, with %echo as a
    third party: each gets what it asked for (as on ROS 1, where rospy has one subscription per topic)."""
    from ipyros.tools.probe import Echo

    n = int(typed_first)
    feeder = make_node(f"w2_share_feeder_{n}").new.publish(f"/share{n}/in", msgType=String).create()
    relayed = listen(make_node, f"w2_share_out_{n}", f"/share{n}/out")

    def wrap():
        w = make_node(f"w2_share_{n}")
        w.baseNode(ECHO_NODE, namespace=f"share{n}", params={"prefix": ""})
        w.reuse.subscribe("in", type=String)
        w.create()

    if not typed_first:
        wrap()
    typed = listen(make_node, f"w2_share_typed_{n}", f"/share{n}/in")
    if typed_first:
        wrap()
    with Echo(f"/share{n}/in", "std_msgs/String") as echo:
        wait_for(lambda: feeder.write(f"/share{n}/in", String(data="x")) or (relayed and len(typed) > 1),
                 timeout=20, interval=0.2, what="the message to reach both the relay and the handler")
        echoed = echo.get(timeout=10)
    assert set(typed) == {"x"} and set(relayed) == {"x"} and echoed.data == "x"
    assert failures == []


def test_an_intercepted_service_makes_the_model_file_round_trip(make_node, tmp_path, caller):
    """A reuse.service beside the new.service that intercepts it: saved, loaded back, still intercepted (issue 25)."""
    from std_srvs.srv import SetBool

    from ipyros import rosNode

    w = make_node("w2_srv_kept")
    w.baseNode(ECHO_NODE, namespace="robot8")
    w.reuse.service("check", type=SetBool)

    def mine(request):
        return SetBool.Response(success=False, message="mine")

    w.new.service("check", SetBool, handler=mine)
    path = w.save(tmp_path / "intercepted.yaml")
    w.shutdown()
    again = rosNode.load(path, {"SetBool": SetBool}, create=True, trust=True)
    try:
        assert [(s.role, s.handler) for s in again.model().services] == [("reuse", None), ("new", "mine")]
        assert caller("/robot8/check", SetBool, SetBool.Request(data=True)).message == "mine"
    finally:
        again.shutdown()


def test_discovery_leaves_no_trace_and_no_false_warning(make_node, notices, session):
    """Right after discover() and create(), the basenode's public names are the wrapper's alone, and nothing
    warns that the basenode does not use them (issue 25: the discovery instance lingered in the graph)."""
    w = make_node("mbw2_clean")
    w.baseNode("move_base").basePackage("ipyros_demo")
    w.discover()
    w.create()
    wait_for(lambda: session.backend.graph_snapshot().publishers.get("/cmd_vel") == ("/mbw2_clean",), timeout=20,
             what="/cmd_vel published by the wrapper alone")
    assert [(node, kind) for node, kind, *_ in session.backend.topic_endpoints("/cmd_vel")] == [
        ("/mbw2_clean", "publisher")]
    assert not [n for n in notices if "(yet)" in n or "does not use" in n], notices


MANAGED_NODE = str(Path(__file__).resolve().parent / "peers" / "managed_node.py")


def test_a_wrapped_lifecycle_basenode_is_managed_under_its_own_name(make_node, caller):
    """A lifecycle manager (a plain rclpy client here) drives a wrapped managed node by its name as before (the one
    its code gives it: no name= given), and the relay follows its state: nothing while inactive, every tick once
    while active (issue 24)."""
    from lifecycle_msgs.msg import Transition
    from lifecycle_msgs.srv import ChangeState, GetState

    ticks = listen(make_node, "lc_listener", "/lc/ticks")
    w = make_node("lc_wrap")
    w.baseNode(MANAGED_NODE, namespace="lc")  # managed_node.py: LifecycleNode.__init__(self, "managed_talker")
    w.reuse.publish("ticks", type=String)
    w.create()

    def change(transition_id: int) -> None:
        assert caller("/lc/managed_talker/change_state", ChangeState,
                      ChangeState.Request(transition=Transition(id=transition_id))).success

    def state() -> str:
        return caller("/lc/managed_talker/get_state", GetState, GetState.Request()).current_state.label

    assert state() == "unconfigured"
    change(Transition.TRANSITION_CONFIGURE)
    wait_for(lambda: any("configured" in line for line in w.base.tail()), what="the basenode configured")
    assert state() == "inactive"
    change(Transition.TRANSITION_ACTIVATE)
    wait_for(lambda: len(ticks) >= 5, timeout=20, what="ticks through the relay once active")
    change(Transition.TRANSITION_DEACTIVATE)
    assert state() == "inactive"
    deactivated = len(ticks)
    time.sleep(0.5)  # a window to see nothing in: the node ticks (10 Hz) without publishing while inactive
    stopped = len(ticks)
    assert stopped <= deactivated + 1, "nothing relayed while inactive (but one on its way)"
    change(Transition.TRANSITION_ACTIVATE)
    wait_for(lambda: len(ticks) >= stopped + 5, timeout=20, what="ticks again once active again")
    numbers = [int(t.split()[1]) for t in ticks]
    assert len(set(numbers)) == len(numbers) and numbers == sorted(numbers), "none doubled, in order"
    first_again = numbers[stopped] if len(numbers) > stopped else None
    assert first_again is not None and first_again > numbers[stopped - 1] + 1, \
        "the ticks counted while inactive were never relayed"
    w.shutdown()


ODD_NODE = """
import rclpy
from std_msgs.msg import String
from {package}.msg import Odd

rclpy.init()
node = rclpy.create_node("odd_node")
odd, plain = node.create_publisher(Odd, "odd", 10), node.create_publisher(String, "plain", 10)
node.create_timer(0.1, lambda: (odd.publish(Odd(x=7, note="n")), plain.publish(String(data="p"))))
print("odd_node ready", flush=True)
try:
    rclpy.spin(node)
except KeyboardInterrupt:
    pass
"""


def _their_node(package_name: str, monkeypatch, tmp_path) -> tuple:
    """A basenode whose message package this session lacks: built for the basenode alone, in another process;
    returns its script and the environment it runs with. What a build here adds is taken back after the test."""
    import os
    import subprocess
    import sys

    package = tmp_path / "src" / package_name
    (package / "msg").mkdir(parents=True)
    (package / "msg" / "Odd.msg").write_text("int32 x\nstring note\ngeometry_msgs/Point where\n")
    theirs = tmp_path / "theirs"
    subprocess.run([sys.executable, "-c", "from ipyros.ros2.msggen import build_messages; import sys; "
                    "build_messages(sys.argv[1], sys.argv[2])", str(package), str(theirs)],
                   check=True, timeout=180, capture_output=True)
    script = tmp_path / "odd_node.py"
    script.write_text(ODD_NODE.format(package=package_name))
    env = {"PYTHONPATH": str(theirs / "ros2" / "python"),
           "LD_LIBRARY_PATH": os.pathsep.join([str(theirs / "ros2" / "lib"), os.environ.get("LD_LIBRARY_PATH", "")])}
    monkeypatch.setattr(sys, "path", list(sys.path))
    for name in ("PYTHONPATH", "LD_LIBRARY_PATH"):
        monkeypatch.setenv(name, os.environ.get(name, ""))
    monkeypatch.setenv("IPYROS_MESSAGES_DIR", str(tmp_path / "ours"))
    with pytest.raises(ImportError):
        __import__(package_name)  # this session lacks it
    return script, env


def test_discovery_builds_a_type_only_the_basenode_has_and_relays_it(make_node, notices, monkeypatch, tmp_path):
    """A basenode from a workspace whose message package this session lacks: discover() learns the type from the
    basenode's own description (REP 2011), builds it, and declares it; the relay carries it and this session can
    read it (issue 24)."""
    script, env = _their_node("ws_odd_msgs", monkeypatch, tmp_path)
    w = make_node("w2_odd")
    w.baseNode(str(script), namespace="robot_odd", env=env)
    interface = w.discover()
    assert interface.not_installed == []
    assert sorted((t.name, t.direction, t.type) for t in w.model().topics) == \
        [("odd", "publish", "ws_odd_msgs/Odd"), ("plain", "publish", "std_msgs/String")]
    assert any(n.startswith("ipyros: built ws_odd_msgs/Odd from /robot_odd/odd_node's own type descriptions")
               for n in notices), notices
    from ws_odd_msgs.msg import Odd

    got: list = []
    make_node("w2_odd_listener").new.subscribe("/robot_odd/odd", handler=lambda m: got.append((m.x, m.note)),
                                               msgType=Odd).create()
    w.create()
    wait_for(lambda: (7, "n") in got, timeout=30, what="the basenode's own type through the relay")
    w.shutdown()


def test_a_reuse_declared_by_hand_of_a_type_only_the_basenode_has_is_learnt_at_create(make_node, notices, monkeypatch,
                                                                                      tmp_path):
    """reuse.publish(type=) of a type this session lacks is taken on ROS 2 too: create() runs the basenode briefly
    as it is to learn the type from its own descriptions, builds it, and opens the relay before the basenode starts
    wrapped. Declared on the running node, a type the running basenode does not describe is refused in one line
    naming the package, and the node runs on as it was (issue 24)."""
    script, env = _their_node("ws_hand_msgs", monkeypatch, tmp_path)
    w = make_node("w2_hand")
    w.baseNode(str(script), namespace="robot_hand", env=env)
    w.reuse.publish("odd", type="ws_hand_msgs/Odd")
    w.reuse.publish("plain", type="std_msgs/String")
    got: list = []
    w.create()
    assert any(n.startswith("ipyros: running basenode /robot_hand/odd_node briefly as it is, to learn "
                            "ws_hand_msgs/Odd") for n in notices), notices
    assert any(n.startswith("ipyros: built ws_hand_msgs/Odd from /robot_hand/odd_node's own type descriptions")
               for n in notices), notices
    from ws_hand_msgs.msg import Odd

    make_node("w2_hand_listener").new.subscribe("/robot_hand/odd", handler=lambda m: got.append((m.x, m.note)),
                                                msgType=Odd).create()
    wait_for(lambda: (7, "n") in got, timeout=30, what="the basenode's own type through the hand-declared relay")
    probes = sum("briefly as it is" in n for n in notices)
    with pytest.raises(MessageTypeError, match=r"ws_none_msgs/Odd not installed here.*pip install ros-ws-none-msgs"):
        w.reuse.publish("late", type="ws_none_msgs/Odd")  # declared on the running node: asked of the running basenode
    assert sum("briefly as it is" in n for n in notices) == probes, "the running basenode was asked, not run again"
    assert [t.name for t in w.model().topics] == ["odd", "plain"], "the refused declaration left nothing behind"
    count = len(got)
    wait_for(lambda: len(got) > count + 3, timeout=30, what="the relay still carrying after the refusal")
    w.shutdown()
