"""The basenode's life as the wrapping node manages it: log, restart, crash, and no orphans."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from ros1_fixtures import master_state, wait_for
from std_msgs.msg import Int32, String

from ipyros.core.errors import BaseNodeError
from ipyros.dsl import engine_of
from ipyros.node import basestart


def alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def wrapped_echo(make_node, name):
    w = make_node(name)
    w.baseNode("echo_node").basePackage("ipyros_test_nodes")
    w.reuse.subscribe("in", type=String).publish("out", type=String)
    return w.create()


def test_log_tail_restart_and_shutdown(make_node, ros_master):
    w = wrapped_echo(make_node, "life_wrapper")
    wait_for(lambda: any("echo_node ready" in line for line in w.base.tail()), what="the basenode's output in its log")
    first = w.base.pid
    w.base.restart()
    assert w.base.pid != first and not alive(first)
    wait_for(lambda: master_state(ros_master)["sub"].get("/life_wrapper/base/in") == ["/echo_node"],
             what="the restarted basenode, remapped again")
    out = []
    make_node("life_listener").new.subscribe("/out", handler=out.append, msgType=String).create()
    feeder = make_node("life_feeder").new.publish("/in", msgType=String).create()
    wait_for(lambda: feeder.write("/in", String("r")) or out, timeout=20, what="traffic after restart")
    pid = w.base.pid
    w.shutdown()
    assert not alive(pid), "shutdown stops the basenode"


def test_a_crash_is_reported_with_exit_code_and_log(make_node, ros_session):
    told = []
    previous = ros_session.notice
    ros_session.notice = told.append
    try:
        w = wrapped_echo(make_node, "crash_wrapper")
        crasher = make_node("crash_sender").new.publish("/crash", msgType=Int32).create()
        wait_for(lambda: engine_of(crasher).writing.writer("/crash")[0].connections(), what="the basenode to subscribe /crash")
        crasher.write("/crash", Int32(3))
        wait_for(lambda: told, timeout=20, what="the crash to be reported")
    finally:
        ros_session.notice = previous
    assert "basenode /echo_node of crash_wrapper exited with code 3; restart it with crash_wrapper.base.restart()" \
        in told[0]
    assert "echo_node ready" in told[0], "the last log lines come with the report"
    assert not w.base.running and w.base.returncode == 3


def test_a_basenode_that_ends_at_start_fails_create_at_once_in_one_notice(make_node, ros_session, tmp_path,
                                                                       monkeypatch):
    script = tmp_path / "broken_node.py"
    script.write_text("import sys, time\n"
                      "print('\\x1b[31m[FATAL] [1.0]: no map given\\x1b[0m', flush=True)\n"
                      "time.sleep(0.3)\n"
                      "sys.exit(4)\n")
    told = []
    previous = ros_session.notice
    ros_session.notice = told.append
    try:
        broken = make_node("broken_wrapper")
        broken.baseNode(str(script)).reuse.publish("map", type=String)
        # Were the registration wait not cut short by the basenode's end, create() would wait for it
        # until the test's own timeout failed it.
        monkeypatch.setattr(basestart, "REGISTRATION_TIMEOUT", 600.0)
        with pytest.raises(BaseNodeError) as caught:
            broken.create()
    finally:
        ros_session.notice = previous
    message = str(caught.value)
    assert "\n" not in message and "exited with code 4 at start" in message
    assert "[FATAL] [1.0]: no map given" in message and "\x1b" not in message, "the log line, without colour codes"
    assert not broken.created and broken.base is None
    assert told == [], "create()'s error says it all: no second notice"


def test_basenode_logs_go_to_the_ros_log_directory(make_node, ros_home):
    w = wrapped_echo(make_node, "log_wrapper")
    assert w.base.log_path.parent == Path(os.environ["ROS_LOG_DIR"]) / "ipyros"
    assert w.base.log_path.name.startswith("echo_node-")


SCRIPT = """
import sys
from ipyros import rosNode
from std_msgs.msg import String
w = rosNode("orphan_wrapper")
w.baseNode("echo_node", namespace="orphans").basePackage("ipyros_test_nodes")
w.reuse.publish("out", type=String)  # a SIGKILLed node stays registered: keep its topics apart
w.create()
print("BASE", w.base.pid, flush=True)
if sys.argv[1] == "wait":
    sys.stdin.read()
"""


def start_interpreter(mode: str) -> tuple[subprocess.Popen, int]:
    proc = subprocess.Popen([sys.executable, "-c", textwrap.dedent(SCRIPT), mode], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=dict(os.environ))
    line = proc.stdout.readline()  # type: ignore[union-attr]
    assert line.startswith("BASE"), line
    return proc, int(line.split()[1])


def test_no_orphan_when_the_interpreter_exits(ros_master):
    proc, base_pid = start_interpreter("exit")
    assert proc.wait(30) == 0
    wait_for(lambda: not alive(base_pid), what="the basenode to stop at exit")


def test_no_orphan_when_the_interpreter_is_killed(ros_master):
    proc, base_pid = start_interpreter("wait")
    assert alive(base_pid)
    proc.send_signal(signal.SIGKILL)
    proc.wait(10)
    wait_for(lambda: not alive(base_pid), what="the basenode to die with its SIGKILLed interpreter")


def test_a_node_that_advertises_after_its_first_input(make_node, ros_session, ros_master):
    """topic_tools throttle (Debian's C++ node) subscribes IN at once but advertises OUT only when
    the first message tells it the type: discovery and create() say so, and the wrap works once it does."""
    told = []
    previous = ros_session.notice
    ros_session.notice = told.append
    try:
        nd = make_node("throttle_wrap", namespace="/thr")
        nd.baseNode("throttle", args=["messages", "in", "50", "out"]).basePackage("topic_tools")
        nd.reuse.publish("out", type=String)
        interface = nd.discover()
        assert interface.not_seen == ["/thr/out (publish)"]
        assert any("/throttle did not use /thr/out (publish) while it was discovered: a node may advertise only "
                   "after its first input" in line for line in told), told
        assert nd.model().topic("/thr/out", "publish", "reuse") is not None, "it stays declared"
        nd.reuse.subscribe("in", type=String)  # ShapeShifter: the master has no type for it
        told.clear()
        nd.create()
        assert any("basenode /thr/throttle does not use reuse.publish('out') of throttle_wrap (yet)" in line
                   for line in told), told
        heard = []
        make_node("throttle_listener").new.subscribe("/thr/out", handler=heard.append, msgType=String).create()
        feeder = make_node("throttle_feeder").new.publish("/thr/in", msgType=String).create()
        wait_for(lambda: feeder.write("/thr/in", String("go")) or heard, timeout=20,
                 what="a message through throttle once it advertised")
        assert heard[0].data == "go"
        assert master_state(ros_master)["pub"]["/thr/throttle_wrap/base/thr/out"] == ["/thr/throttle"]
    finally:
        ros_session.notice = previous
