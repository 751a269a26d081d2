"""A guard placed on another machine's keeper (``nd.guard(..., machine=NAME)``), on ROS 1, with real processes: the
keeper, a plain subscriber standing for the motors, sessions in this process and in processes of their own (killed
as a crash kills them). The link itself cut between two network namespaces is tests/both/test_machine_link.py's."""

from __future__ import annotations

import json
import os
import signal
import textwrap
import time

import pytest
from geometry_msgs.msg import Twist
from helpers import descendants, pid_alive
from keepers import Keepers
from peer import Peer
from std_msgs.msg import Int32, String
from support import wait_for

from bench.machine_link import twists
from ipyros.core import errors
from ipyros.dsl import engine_of
from ipyros.processes.keeper import Token, token_path

LIMITS = {"linear.x": (-0.5, 0.5)}


@pytest.fixture
def keeper(session):
    """Start a keeper (default name ``testbot``) on the run's master; after the test, ended with all it started."""
    keepers = Keepers("ROS 1")
    yield lambda name="testbot", *allow: keepers.start(name, *allow)
    keepers.end()


def test_a_placed_guard_clamps_on_the_machine_and_status_says_where_it_runs(make_node, peer, keeper):
    machine = keeper()
    motors = peer("listen_twist.py", "/placed1/cmd_vel", "--name=motors1")
    motors.wait_line("ready")
    nd = make_node("placed1")
    nd.new.publish("/placed1/cmd_vel", msgType=Twist)
    nd.guard("/placed1/cmd_vel", limits=LIMITS, machine="testbot")
    nd.create()
    fast = Twist()
    fast.linear.x = 2.0
    for _ in range(10):
        nd.write("/placed1/cmd_vel", fast)
        time.sleep(0.05)
    wait_for(lambda: len(twists(motors)) >= 5, timeout=20, what="commands at the motors")
    assert {x for x, _ in twists(motors)} == {0.5}, "clamped on the way"
    # The keeper's own gate, not only the session's: a message straight to it, past the session
    placed = engine_of(nd).guards.live["/placed1/cmd_vel"]
    other = make_node("placed1_bypass")
    other.new.publish(f"/ipyros/machines/testbot/guards/{placed.id}/in", msgType=Twist)
    other.create()
    fast.linear.x = 3.0
    wait_for(lambda: other.write(f"/ipyros/machines/testbot/guards/{placed.id}/in", fast) or len(twists(motors)) >= 12,
             timeout=20, interval=0.1, what="messages sent past the session")
    assert {x for x, _ in twists(motors)} == {0.5}, "clamped on the robot"
    (state,) = engine_of(nd).status().guards
    assert state.state == "passing (on testbot)" and state.figures.clamped >= 5
    assert "on testbot" in str(engine_of(nd).status())
    # %estop reaches the robot: the stop message holds there until released
    nd.estop()
    stopped_at = time.monotonic()
    wait_for(lambda: any(x == 0.0 and t > stopped_at for x, t in twists(motors)), timeout=20, what="the e-stop")
    wait_for(lambda: engine_of(nd).status().guards[0].state == "e-stopped (on testbot)", timeout=10,
             what="the keeper's report of it")
    nd.release()
    released_at = time.monotonic()
    fast.linear.x = 0.2
    wait_for(lambda: nd.write("/placed1/cmd_vel", fast) or any(x == 0.2 and t > released_at for x, t in twists(motors)),
             timeout=20, interval=0.1, what="commands after the release")
    machine.wait_line("placed guard /placed1/cmd_vel", timeout=10)


def test_the_guards_stop_process_killed_on_the_machine_the_keeper_sends_the_stop_until_released(make_node, peer,
                                                                                                  keeper, notices):
    """Fail closed on the robot: its stop process SIGKILLed, the keeper puts the stop message in place of every
    command and sends it at the guard's rate; the session says so once and %status shows it; a release starts the
    process again and commands pass."""
    machine = keeper()
    motors = peer("listen_twist.py", "/placed4/cmd_vel", "--name=motors4")
    motors.wait_line("ready")
    nd = make_node("placed4")
    nd.new.publish("/placed4/cmd_vel", msgType=Twist)
    nd.guard("/placed4/cmd_vel", limits=LIMITS, machine="testbot", repeat=20.0)
    nd.create()
    command = Twist()
    command.linear.x = 0.3
    wait_for(lambda: nd.write("/placed4/cmd_vel", command) or any(x == 0.3 for x, _ in twists(motors)), timeout=20,
             interval=0.05, what="commands at the motors")
    (stop_process,) = descendants(machine.proc.pid)
    os.kill(stop_process, signal.SIGKILL)
    killed_at = time.monotonic()
    wait_for(lambda: any("its stop process ended (killed by signal 9" in line for line in machine.lines),
             timeout=10, what="the keeper's word")
    wait_for(lambda: any("its stop process ended on machine testbot (killed by signal 9)" in n for n in notices),
             timeout=10, what="the session's word")
    said_at = time.monotonic()
    for _ in range(20):  # the session goes on writing commands: none passes, the stop message comes at 20 Hz
        nd.write("/placed4/cmd_vel", command)
        time.sleep(0.05)
    after = [(x, t) for x, t in twists(motors) if t > said_at]
    assert after and all(x == 0.0 for x, _ in after), after[:5]
    assert len(after) >= 10, "the stop message at the guard's rate, from the keeper"
    (state,) = engine_of(nd).status().guards
    assert state.state == "e-stopped (its stop process ended: killed by signal 9) (on testbot)", state.state
    assert not any(x == 0.3 and t > killed_at + 0.5 for x, t in twists(motors))
    nd.release()
    released_at = time.monotonic()
    wait_for(lambda: nd.write("/placed4/cmd_vel", command) or any(x == 0.3 and t > released_at
                                                                   for x, t in twists(motors)),
             timeout=30, interval=0.05, what="commands after the release")
    assert len(descendants(machine.proc.pid)) == 1, "its stop process started again"
    wait_for(lambda: engine_of(nd).status().guards[0].state == "passing (on testbot)", timeout=10, what="passing")


SESSION = """
import sys, time
from ipyros import rosNode
from geometry_msgs.msg import Twist
nd = rosNode("placed_{tag}")
nd.new.publish("/{tag}/cmd_vel", msgType=Twist)
nd.guard("/{tag}/cmd_vel", limits={{"linear.x": (-0.5, 0.5)}}, machine="testbot", lease=0.5, machine_grace=2.0,
         grace=0.5)
nd.create()
print("created", flush=True)
m = Twist()
m.linear.x = 0.3
while True:
    nd.write("/{tag}/cmd_vel", m)
    time.sleep(0.05)
"""


def test_a_killed_session_stops_the_robot_within_its_lease_and_leaves_nothing_after_its_grace(peer, keeper, tmp_path):
    machine = keeper()
    motors = peer("listen_twist.py", "/placed2/cmd_vel", "--name=motors2")
    motors.wait_line("ready")
    script = tmp_path / "session.py"
    script.write_text(SESSION.format(tag="placed2"))
    laptop = Peer(str(script))
    try:
        laptop.wait_line("created", timeout=60)
        wait_for(lambda: sum(x == 0.3 for x, _ in twists(motors)) >= 10, timeout=20, what="commands at the motors")
        guards = descendants(machine.proc.pid)
        assert guards, "the guard's stop process runs beside the keeper"
        killed_at = time.monotonic()
        os.kill(laptop.proc.pid, signal.SIGKILL)  # a crash: no word to the keeper
        first = wait_for(lambda: next((t for x, t in twists(motors) if x == 0.0 and t > killed_at), None),
                         timeout=10, what="the stop message at the motors")
        # lease 0.5 s (the bench measures how soon: lease + 50 ms p99); here only that it comes, and not long after
        assert first - killed_at < 0.5 + 2.0, first - killed_at  # 2 s: what a loaded machine may add
        assert all(x == 0.0 for x, t in twists(motors) if t > first), "nothing but the stop message after it"
        wait_for(lambda: any("silent past its grace" in line for line in machine.lines), timeout=20,
                 what="the keeper to end the guard after its grace")
        wait_for(lambda: not any(pid_alive(pid) for pid in guards), timeout=20, what="the guard's process to end")
    finally:
        laptop.stop()


def test_requests_unsigned_replayed_or_forged_are_refused_in_one_line(make_node, keeper, tmp_path):
    machine = keeper()
    info = json.loads(wait_for(lambda: _latched("/ipyros/machines/testbot/info"), timeout=20, what="its info"))
    replies: list[dict] = []
    nd = make_node("asker")
    nd.new.publish("/ipyros/machines/testbot/request", msgType=String)
    nd.new.subscribe("/ipyros/machines/testbot/reply", handler=lambda m: replies.append(json.loads(m.data)),
                     msgType=String)
    nd.create()
    token = Token.read(token_path("testbot"), "testbot")
    forged = Token(b"\0" * 32)
    body = {"epoch": info["epoch"], "from": "tester", "op": "estop", "id": "abcdef"}
    asks = [("unsigned", json.dumps({"body": json.dumps({**body, "n": 1})}), "unsigned request"),
            ("forged", forged.signed({**body, "n": 2}), "bad signature"),
            ("signed", token.signed({**body, "n": 3}), "no guard abcdef of this session here"),
            ("replayed", token.signed({**body, "n": 3}), "replayed request"),
            ("old start", token.signed({**body, "n": 4, "epoch": "0"}), "another start of this keeper")]
    wait_for(lambda: nd.write("/ipyros/machines/testbot/request", String(data=asks[0][1])) or replies, timeout=20,
             interval=0.5, what="an answer from the keeper")  # asked again until its subscriber has found ours
    for what, text, why in asks:
        replies.clear()
        nd.write("/ipyros/machines/testbot/request", String(data=text))
        wait_for(lambda: replies, timeout=20, what=f"an answer to the {what} request")
        assert replies[-1]["ok"] is False and why in replies[-1]["error"], (what, replies[-1])
        assert "\n" not in replies[-1]["error"]
        wait_for(lambda: any(line.endswith(replies[-1]["error"]) for line in machine.lines), timeout=10,
                 what=f"the keeper's log of the {what} request")


def test_a_guard_placed_wrong_is_one_line(make_node, tmp_path, monkeypatch):
    nd = make_node("placed_wrong")
    nd.new.publish("/placed_wrong/cmd_vel", msgType=Twist)
    with pytest.raises(errors.DeclarationError, match=r"no token for machine nowhere at .*: copy it there"):
        nd.guard("/placed_wrong/cmd_vel", machine="nowhere")
    with pytest.raises(errors.DeclarationError, match="give a word"):
        nd.guard("/placed_wrong/cmd_vel", machine="robot/1")
    with pytest.raises(errors.DeclarationError, match="lease= and machine_grace= are for a guard kept by another"):
        nd.guard("/placed_wrong/cmd_vel", lease=0.2)
    Token.made_or_read(token_path("quiet"))
    with pytest.raises(errors.DeclarationError, match="lease=0: give the seconds"):
        nd.guard("/placed_wrong/cmd_vel", machine="quiet", lease=0)
    nd.guard("/placed_wrong/cmd_vel", machine="quiet")
    with pytest.raises(errors.DeclarationError, match="moves only when removed first"):
        nd.guard("/placed_wrong/cmd_vel")
    monkeypatch.setattr("ipyros.node.keeperlink.FIND", 1.0)
    with pytest.raises(errors.IpyrosError, match="no keeper of machine quiet answers on this ROS graph"):
        nd.create()
    assert not engine_of(nd).created
    token_path("quiet").unlink()


def _latched(topic: str):
    import rospy

    try:
        return rospy.wait_for_message(topic, String, timeout=2.0).data
    except rospy.ROSException:
        return None


def test_a_basenode_placed_on_the_machine_runs_there_wrapped_and_crashes_are_told(make_node, keeper, notices):
    """The keeper starts an allowed package's executable with the session's remaps and arguments; the wrapping node
    relays it; nd.base is its handle there (pid, tail, restart); a crash there is told with its last lines; the
    node's shutdown stops it there."""
    machine = keeper("testbot", "ipyros_test_nodes")
    assert "the basenodes of ipyros_test_nodes" in machine.lines[-1]
    nd = make_node("placedbase1")
    nd.baseNode("echo_node", args=["--prefix", "robot> "]).basePackage("ipyros_test_nodes").machine("testbot")
    nd.reuse.subscribe("in", type=String).publish("out", type=String)
    nd.reuse.service("~reset", type="std_srvs/Empty")
    nd.create()
    pid = nd.base.pid
    machine.wait_line("service relay /placedbase1/base/echo_node/reset -> /echo_node/reset for ", timeout=10)
    import rospy
    from std_srvs.srv import Empty

    rospy.wait_for_service("/echo_node/reset", timeout=20)
    rospy.ServiceProxy("/echo_node/reset", Empty)()
    wait_for(lambda: any("reset" == line.strip() for line in nd.base.tail()), timeout=20,
             what="the basenode on the machine to serve the call, relayed there")
    assert pid in descendants(machine.proc.pid), "it runs as the keeper's child"
    wait_for(lambda: any("echo_node ready" in line for line in nd.base.tail()), timeout=20, what="its log there")
    machine.wait_line("started basenode ipyros_test_nodes/echo_node", timeout=10)
    out: list[str] = []
    make_node("placedbase1_listener").new.subscribe("/out", handler=lambda m: out.append(m.data), msgType=String) \
        .create()
    feeder = make_node("placedbase1_feeder").new.publish("/in", msgType=String).create()
    wait_for(lambda: feeder.write("/in", String("hi")) or "robot> hi" in out, timeout=20, interval=0.2,
             what="a message through the placed basenode, relayed")
    crasher = make_node("placedbase1_crash").new.publish("/crash", msgType=Int32).create()
    wait_for(lambda: crasher.write("/crash", Int32(5)) or not nd.base.running, timeout=20,
             interval=0.2, what="the crash on the machine")
    wait_for(lambda: any("exited with code 5" in n for n in notices), timeout=10, what="the crash told")
    told = next(n for n in notices if "exited with code 5" in n)
    assert "basenode /echo_node of placedbase1 on testbot exited" in told and "last words on stderr" in told, told
    nd.base.restart()
    wait_for(lambda: nd.base.running and nd.base.pid not in (None, pid), timeout=20, what="it runs again")
    again = nd.base.pid
    nd.shutdown()
    wait_for(lambda: not pid_alive(again), timeout=20, what="the node's shutdown to stop it there")
    machine.wait_line("stopped basenode ipyros_test_nodes/echo_node", timeout=10)


def test_a_placed_basenodes_relays_run_on_its_machine_through_a_guard_there_and_a_handler_takes_one_over(
        make_node, peer, keeper, session):
    """The relays of a basenode placed on the robot run there, beside it (its topics never cross to the session),
    a relay onto a guarded topic passes the gate the keeper keeps there (clamped; %estop holds it at the stop
    message); a handler declared on the running node takes a topic over: the keeper's relay goes, the session's
    handler gets the basenode's messages (across the link once) and its writes pass the guard on the robot."""
    machine = keeper("testbot", "topic_tools")
    motors = peer("listen_twist.py", "/pr_cmd_vel", "--name=motors5")
    motors.wait_line("ready")
    nd = make_node("placedrelay")
    nd.baseNode("relay", args=["pr_in", "pr_cmd_vel"]).basePackage("topic_tools").machine("testbot")
    nd.reuse.subscribe("/pr_in", type=Twist).publish("/pr_cmd_vel", type=Twist)
    nd.guard("/pr_cmd_vel", limits=LIMITS, machine="testbot")
    nd.create()
    internal_out = "/placedrelay/base/pr_cmd_vel"
    assert "(through its guard)" in machine.wait_line(f"relay {internal_out} -> /pr_cmd_vel for ", timeout=10)
    machine.wait_line("relay /pr_in -> /placedrelay/base/pr_in for ", timeout=10)
    feeder = make_node("placedrelay_feeder").new.publish("/pr_in", msgType=Twist).create()
    fast = Twist()
    fast.linear.x = 2.0
    wait_for(lambda: feeder.write("/pr_in", fast) or len(twists(motors)) >= 5, timeout=30, interval=0.05,
             what="commands through the basenode on the machine, relayed there")
    assert {x for x, _ in twists(motors)} == {0.5}, "clamped by the guard on the machine"
    # the guarded relay runs in the keeper, behind the gate; the other in the relays' own process there
    graph = session.backend.graph_snapshot()
    assert set(graph.subscribers.get(internal_out, ())) == {"/ipyros_machine_testbot"}, graph.subscribers
    (host,) = [n for n in graph.subscribers.get("/pr_in", ()) if n.startswith("/ipyros_machine_testbot_relays_")]
    said = machine.wait_line("their process runs (pid ", timeout=10)
    host_pid = int(said.split("(pid ")[1].rstrip(")"))
    assert host_pid in descendants(machine.proc.pid)
    rows = lambda: {r.name: r for r in engine_of(nd).status().rows}  # noqa: E731
    wait_for(lambda: rows()["/pr_cmd_vel"].calls > 0, timeout=10, what="the keeper's count in %status")
    assert rows()["/pr_cmd_vel"].kind == "relay on testbot"
    # %estop: the stop message holds on the robot, also for what its relay sends
    nd.estop()
    stopped_at = time.monotonic()
    wait_for(lambda: feeder.write("/pr_in", fast) or sum(t > stopped_at + 0.3 for _, t in twists(motors)) >= 5,
             timeout=20, interval=0.05, what="commands after the e-stop")
    assert {x for x, t in twists(motors) if t > stopped_at + 0.3} == {0.0}
    nd.release()
    # A handler takes the relayed output over on the running node: it gets what the basenode sends and writes
    seen: list[float] = []

    def slower(msg):
        seen.append(msg.linear.x)
        msg.linear.x = 0.25
        nd.write("/pr_cmd_vel", msg)

    nd.new.subscribe("/pr_cmd_vel", handler=slower, msgType=Twist)
    wait_for(lambda: any(f"relay {internal_out} -> /pr_cmd_vel of " in line and "removed" in line
                         for line in machine.lines),
             timeout=10, what="the keeper's relay to go")
    taken_at = time.monotonic()
    wait_for(lambda: feeder.write("/pr_in", fast) or any(x == 0.25 and t > taken_at for x, t in twists(motors)),
             timeout=30, interval=0.05, what="the handler's writes at the motors")
    assert 2.0 in seen, "the handler got the basenode's own message"
    assert {x for x, t in twists(motors) if t > taken_at + 0.5} <= {0.25}
    nd.shutdown()
    wait_for(lambda: any("relay /pr_in -> /placedrelay/base/pr_in of " in line and "removed" in line
                         for line in machine.lines),
             timeout=10, what="the last relay to go with the node")
    wait_for(lambda: not pid_alive(host_pid), timeout=20, what="the relays' process to end with them")


def test_a_placed_basenode_outside_what_the_keeper_allows_is_refused_in_one_line(make_node, keeper, tmp_path):
    machine = keeper("testbot", "ipyros_test_nodes")
    nd = make_node("placedbase2")
    nd.baseNode("relay").basePackage("topic_tools").machine("testbot")
    with pytest.raises(errors.BaseNodeError, match=r"machine testbot refused: package 'topic_tools' is not allowed on "
                                                   r"this machine \(its keeper allows ipyros_test_nodes\): start the "
                                                   r"keeper with --allow topic_tools"):
        nd.create()
    assert not engine_of(nd).created
    wait_for(lambda: any("refused a request" in line and "topic_tools" in line for line in machine.lines), timeout=10,
             what="the keeper's log of the refusal")
    path = make_node("placedbase3")
    path.baseNode(str(tmp_path / "evil.sh"))
    with pytest.raises(errors.DeclarationError, match=r"the keeper starts a package's executable by its name"):
        path.machine("testbot")
    later = make_node("placedbase4").machine("testbot")  # placed first, its basenode declared after
    later.baseNode(str(tmp_path / "evil.sh"))
    with pytest.raises(errors.BaseNodeError, match=r"the keeper starts a package's executable by its name"):
        later.create()
    with pytest.raises(errors.DeclarationError, match="grace=-1: give the seconds"):
        nd.machine("testbot", grace=-1)
    with pytest.raises(errors.DeclarationError, match="no token for machine elsewhere"):
        nd.machine("elsewhere")
    assert not descendants(machine.proc.pid), "nothing started on the machine"
    # the placement is kept: a saved node places its basenode and its guard again, and its model file says where
    kept = make_node("placedbase7")
    kept.baseNode("echo_node").basePackage("ipyros_test_nodes").machine("testbot", grace=5.0)
    kept.reuse.publish("out", type=String)
    kept.guard("out", machine="testbot", lease=0.3)
    text = kept.save(tmp_path / "kept.py").read_text()
    assert "placedbase7.machine('testbot', grace=5.0)" in text and "machine='testbot', lease=0.3" in text, text
    model = kept.save(tmp_path / "kept.yaml").read_text()
    assert "machine: testbot" in model and "machine_grace: 5.0" in model, model


BASE_SESSION = """
import time
from ipyros import rosNode
from std_msgs.msg import String
nd = rosNode("placedbase5")
nd.baseNode("echo_node").basePackage("ipyros_test_nodes").machine("testbot", grace=2.0)
nd.reuse.subscribe("in", type=String).publish("out", type=String)
nd.create()
print("created", nd.base.pid, flush=True)
while True:
    time.sleep(1)
"""


def test_a_placed_basenode_ends_after_its_sessions_grace_and_with_its_keeper(make_node, keeper, notices, tmp_path):
    """No orphans on the robot: the session SIGKILLed, the keeper stops its basenode once the grace is over; the
    keeper killed, its basenode ends with it and the session says so."""
    machine = keeper("testbot", "ipyros_test_nodes")
    script = tmp_path / "session.py"
    script.write_text(BASE_SESSION)
    laptop = Peer(str(script))
    try:
        pid = int(laptop.wait_line("created", timeout=60).split()[1])
        assert pid in descendants(machine.proc.pid)
        os.kill(laptop.proc.pid, signal.SIGKILL)
        killed_at = time.monotonic()
        time.sleep(1.0)
        assert pid_alive(pid), "kept for its grace (2 s)"
        wait_for(lambda: not pid_alive(pid), timeout=20, what="the keeper to stop it after the grace")
        assert time.monotonic() - killed_at >= 2.0
        wait_for(lambda: any("silent past its grace (2 s): stopped" in line for line in machine.lines), timeout=10,
                 what="the keeper's word")
    finally:
        laptop.stop()
    nd = make_node("placedbase6")
    nd.baseNode("echo_node").basePackage("ipyros_test_nodes").machine("testbot")
    nd.reuse.subscribe("in", type=String).publish("out", type=String)
    nd.create()
    pid = nd.base.pid
    machine.proc.kill()
    wait_for(lambda: not pid_alive(pid), timeout=20, what="its basenode to end with the keeper")
    wait_for(lambda: any("no word from machine testbot" in n for n in notices), timeout=20, what="the session's word")
    nd.shutdown()  # its machine gone: each thing's answer is waited for a moment, not its whole time
    assert any("did not answer 'stop_base' within 1 s" in n for n in notices), notices



def test_machines_lists_the_keepers_with_what_they_allow_and_keep_and_tab_completes_their_names(ip, keeper):
    from IPython.core.completer import provisionalcompleter
    from shell import ok

    keeper("testbot", "ipyros_test_nodes")
    ok(ip, "from ipyros import rosNode\nfrom geometry_msgs.msg import Twist\nnd = rosNode('listed')\n"
           "nd.new.publish('/listed/cmd_vel', msgType=Twist)\n"
           "nd.guard('/listed/cmd_vel', limits={'linear.x': (-0.5, 0.5)}, machine='testbot')\nnd.create()")
    machines = ok(ip, "%machines").result
    (testbot,) = [m for m in machines if m.name == "testbot"]
    assert testbot.allows == {"ipyros_test_nodes": ["count_server", "echo_node"]} and testbot.token and testbot.ros == "ROS 1"
    assert testbot.guards == ("/listed/cmd_vel",) and testbot.rtt_ms is not None and 0 < testbot.rtt_ms < 1000
    text = str(machines)
    assert "testbot" in text and "ipyros_test_nodes" in text and "/listed/cmd_vel" in text, text

    def offered(text: str) -> list[str]:
        with provisionalcompleter():
            return [c.text for c in ip.Completer.completions(text, len(text)) if c.text]

    wait_for(lambda: "testbot" in offered('nd.machine("test'), timeout=20, what="the machine's name offered")
    assert "testbot" in offered("nd.guard('/listed/cmd_vel', machine='te")


def test_tab_offers_the_packages_and_executables_a_keeper_allows_though_not_installed_here(ip, keeper, tmp_path,
                                                                                          monkeypatch):
    """A placed basenode's package lives on the robot: TAB offers what the keepers on the graph allow."""
    from IPython.core.completer import provisionalcompleter
    from shell import ok

    package = tmp_path / "robot_only_pkg"
    package.mkdir()
    (package / "package.xml").write_text('<?xml version="1.0"?><package format="2"><name>robot_only_pkg</name>'
                                         '<version>0.0.1</version><description>on the robot</description>'
                                         '<maintainer email="a@b.c">a</maintainer><license>MIT</license></package>')
    drive = package / "drive_node"
    drive.write_text("#!/bin/sh\nexec sleep 600\n")
    drive.chmod(0o755)
    here = os.environ.get("ROS_PACKAGE_PATH", "")
    monkeypatch.setenv("ROS_PACKAGE_PATH", os.pathsep.join([str(tmp_path), here]))
    keeper("testbot", "robot_only_pkg")  # the robot's ROS_PACKAGE_PATH has it
    monkeypatch.setenv("ROS_PACKAGE_PATH", here)  # the laptop's does not
    ok(ip, "from ipyros import rosNode\ntabbed = rosNode('tabbed')")

    def offered(text: str) -> list[str]:
        with provisionalcompleter():
            return [c.text for c in ip.Completer.completions(text, len(text)) if c.text]

    assert "robot_only_pkg" in wait_for(lambda: offered('tabbed.basePackage("robot_o'), timeout=20,
                                        what="the keeper's package offered")
    ok(ip, "tabbed.baseNode('drive_node').basePackage('robot_only_pkg')")
    assert offered('tabbed.baseNode("dri') == ["drive_node"]


def test_wrap_places_the_basenode_on_a_machine_and_its_export_says_where_to_start_it(ip, keeper, tmp_path):
    from shell import ok

    machine = keeper("testbot", "ipyros_test_nodes")
    ok(ip, "%wrap ipyros_test_nodes echo_node --as robo --machine testbot")
    robo = ip.user_ns["robo"]
    assert robo.base.pid in descendants(machine.proc.pid), "started by the keeper"
    machine.wait_line(" -> /out for ", timeout=10)  # its relays run there
    saved = robo.save(tmp_path / "robo_saved.py").read_text()
    assert ".machine('testbot'" in saved or '.machine("testbot"' in saved, saved
    package = robo.export(tmp_path / "robo_pkg")
    launch = (package / "launch" / "robo.launch").read_text()
    assert "ran on machine testbot" in launch and "install and start" in launch
    robo.shutdown()


def test_the_relays_process_killed_on_the_machine_is_told_at_the_prompt(keeper, make_node, notices):
    machine = keeper("testbot", "ipyros_test_nodes")
    nd = make_node("placedbase7")
    nd.baseNode("echo_node").basePackage("ipyros_test_nodes").machine("testbot")
    nd.reuse.subscribe("in", type=String).publish("out", type=String)
    nd.create()
    said = machine.wait_line("their process runs (pid ", timeout=10)
    host = int(said.split("(pid ")[1].rstrip(")"))
    os.kill(host, signal.SIGKILL)
    wait_for(lambda: any("their process ended (killed by signal 9" in line for line in machine.lines), timeout=10,
             what="the keeper's word")
    wait_for(lambda: any("the relays of /placedbase7 on machine testbot ended (killed by signal 9)" in n
                         for n in notices), timeout=10, what="the session's word")


def test_a_placed_basenodes_action_is_relayed_on_its_machine_then_intercepted_in_the_session(keeper, make_node,
                                                                                             counting, session):
    """The action relay of a placed basenode runs on its machine (goals, feedback, result and a cancel pass through
    it); a handler declared on the running node takes the action over in the session and forwards to the basenode
    there; removed, the keeper relays it again."""
    machine = keeper("testbot", "ipyros_test_nodes")
    nd = make_node("placedaction")
    nd.baseNode("count_server").basePackage("ipyros_test_nodes").machine("testbot")
    nd.reuse.action("count", type=counting.type)
    nd.create()
    machine.wait_line("action relay /placedaction/base/count -> /count for ", timeout=20)
    assert counting.plain_send("/count", 4) == ("succeeded", 4, [1, 2, 3, 4])
    state, reached, _ = counting.plain_send("/count", 1000, cancel_after=2)
    assert state == "cancelled" and reached < 1000
    wait_for(lambda: "cancelled 1000" in nd.base.tail(), timeout=20, what="the cancel to reach the basenode there")
    goals = lambda: set(session.backend.graph_snapshot().subscribers.get("/count/goal", ()))  # noqa: E731
    (host,) = goals()
    assert host.startswith("/ipyros_machine_testbot_relays_"), "the goals go to the relays' process there"

    def clamp(goal, action):  # the goal changed on its way: the basenode on the robot counts to 3 at most
        return action.forward(counting.goal(min(counting.n_of(goal), 3)))

    nd.new.action("count", counting.type, clamp)
    wait_for(lambda: any("action relay /placedaction/base/count -> /count of " in line
                         and "removed" in line for line in machine.lines), timeout=20, what="the keeper's relay to go")
    assert counting.plain_send("/count", 10) == ("succeeded", 3, [1, 2, 3])
    assert "goal 3" in nd.base.tail()
    assert goals() and not any(n.startswith("/ipyros_machine_") for n in goals()), "to the session's handler now"
    nd.remove(action="count")
    nd.reuse.action("count", type=counting.type)  # given back to the basenode, relayed on its machine again
    assert counting.plain_send("/count", 5)[:2] == ("succeeded", 5)
    assert sum("action relay /placedaction/base/count -> /count for " in line for line in machine.lines) == 2
    nd.shutdown()
