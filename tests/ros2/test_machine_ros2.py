"""A guard and a basenode placed on a machine's keeper (``python -m ipyros.machine``) on ROS 2, with real processes:
the keeper an rclpy node of its own in the session's domain, a plain subscriber standing for the motors."""

from __future__ import annotations

import os
import signal
import sys
import time

import pytest
from geometry_msgs.msg import Twist
from helpers import descendants, pid_alive, use_ament_echo
from keepers import Keepers
from peer import Peer
from std_msgs.msg import String
from support import wait_for

from bench.machine_link import twists
from ipyros.dsl import engine_of

LIMITS = {"linear.x": (-0.5, 0.5)}


@pytest.fixture
def keeper():
    """Start the keeper ``testbot2`` (allowing ``allow``); after the test, ended with all it started."""
    keepers = Keepers("ROS 2")
    yield lambda *allow: keepers.start("testbot2", *allow)
    keepers.end()


def test_a_guard_placed_on_a_ros2_keeper_clamps_there_and_the_estop_reaches_it(make_node, peer, keeper):
    machine = keeper()
    motors = peer("listen_twist.py", "/placed21/cmd_vel", "--name=motors21")
    motors.wait_line("ready")
    nd = make_node("placed21")
    nd.new.publish("/placed21/cmd_vel", msgType=Twist)
    nd.guard("/placed21/cmd_vel", limits=LIMITS, machine="testbot2")
    nd.create()
    fast = Twist()
    fast.linear.x = 2.0
    wait_for(lambda: nd.write("/placed21/cmd_vel", fast) or len(twists(motors)) >= 5, timeout=30, interval=0.05,
             what="commands at the motors")
    assert {x for x, _ in twists(motors)} == {0.5}, "clamped on the way"
    wait_for(lambda: engine_of(nd).status().guards[0].state == "passing (on testbot2)", timeout=10, what="its state")
    nd.estop()
    stopped_at = time.monotonic()
    wait_for(lambda: any(x == 0.0 and t > stopped_at for x, t in twists(motors)), timeout=20, what="the e-stop")
    nd.release()
    released_at = time.monotonic()
    fast.linear.x = 0.2
    wait_for(lambda: nd.write("/placed21/cmd_vel", fast) or any(x == 0.2 and t > released_at
                                                                 for x, t in twists(motors)),
             timeout=20, interval=0.1, what="commands after the release")
    machine.wait_line("placed guard /placed21/cmd_vel", timeout=10)


SESSION = """
import time
from ipyros import rosNode
from geometry_msgs.msg import Twist
nd = rosNode("placed22")
nd.new.publish("/placed22/cmd_vel", msgType=Twist)
nd.guard("/placed22/cmd_vel", limits={"linear.x": (-0.5, 0.5)}, machine="testbot2", lease=0.5, machine_grace=2.0,
         grace=0.5)
nd.create()
print("created", flush=True)
m = Twist()
m.linear.x = 0.3
while True:
    nd.write("/placed22/cmd_vel", m)
    time.sleep(0.05)
"""


def test_a_killed_ros2_session_stops_the_robot_within_its_lease(peer, keeper, tmp_path):
    machine = keeper()
    motors = peer("listen_twist.py", "/placed22/cmd_vel", "--name=motors22")
    motors.wait_line("ready")
    script = tmp_path / "session.py"
    script.write_text(SESSION)
    laptop = Peer(str(script))
    try:
        laptop.wait_line("created", timeout=60)
        wait_for(lambda: sum(x == 0.3 for x, _ in twists(motors)) >= 10, timeout=30, what="commands at the motors")
        killed_at = time.monotonic()
        os.kill(laptop.proc.pid, signal.SIGKILL)
        first = wait_for(lambda: next((t for x, t in twists(motors) if x == 0.0 and t > killed_at), None),
                         timeout=10, what="the stop message at the motors")
        assert first - killed_at < 0.5 + 2.0, first - killed_at  # the lease, and what a loaded machine adds
        wait_for(lambda: any("silent past its grace" in line for line in machine.lines), timeout=20,
                 what="the keeper to end the guard after its grace")
    finally:
        laptop.stop()


def _answered(session, name: str, cls: type):
    try:
        return session.backend.call(name, cls, cls.Request(data=True), 5.0)
    except Exception:  # noqa: BLE001 - not found yet: asked again
        return None


def test_a_basenode_placed_on_a_ros2_keeper_runs_there_and_is_relayed(make_node, keeper, tmp_path, monkeypatch,
                                                                       session):
    use_ament_echo(tmp_path, monkeypatch, sys.executable)
    machine = keeper("echo_pkg")
    assert "the basenodes of echo_pkg" in machine.lines[-1]
    w = make_node("placed23")
    w.baseNode("echo_node", namespace="robot23").basePackage("echo_pkg").machine("testbot2")
    w.reuse.subscribe("in", type=String).publish("out", type=String)
    w.reuse.service("check", type="std_srvs/SetBool")
    w.create()
    pid = w.base.pid
    machine.wait_line(" -> /robot23/check for ", timeout=10)  # its service relay, on the machine
    from std_srvs.srv import SetBool

    answer = wait_for(lambda: _answered(session, "/robot23/check", SetBool), timeout=30, interval=0.5,
                      what="the basenode's service, relayed on the machine")
    assert answer.success and answer.message.endswith("checked"), answer
    assert pid in descendants(machine.proc.pid), "it runs as the keeper's child"
    out: list[str] = []
    make_node("placed23_ear").new.subscribe("/robot23/out", handler=lambda m: out.append(m.data),
                                            msgType=String).create()
    mouth = make_node("placed23_mouth").new.publish("/robot23/in", msgType=String).create()
    wait_for(lambda: mouth.write("/robot23/in", String(data="hi")) or out, timeout=30, interval=0.2,
             what="a message through the placed basenode, relayed")
    # relayed on the machine, beside it, by the keeper (its relays' own node): not by this session
    machine.wait_line(" -> /robot23/out for ", timeout=10)
    relayed = wait_for(lambda: engine_of(w).status().rows and
                       {r.name: r for r in engine_of(w).status().rows}["/robot23/out"], timeout=10, what="its row")
    assert relayed.kind == "relay on testbot2"
    wait_for(lambda: {r.name: r for r in engine_of(w).status().rows}["/robot23/out"].calls > 0, timeout=10,
             what="the keeper's count of what it relayed")
    w.shutdown()
    wait_for(lambda: not pid_alive(pid), timeout=20, what="the node's shutdown to stop it there")


def test_a_placed_basenodes_action_is_relayed_on_a_ros2_keeper_then_intercepted_in_the_session(
        keeper, make_node, counting, tmp_path, monkeypatch):
    """ROS 2's action relay of a placed basenode runs on its machine (goal, feedback, result, cancel); a handler
    declared on the running node takes the action over in the session; removed, the keeper relays it again."""
    use_ament_echo(tmp_path, monkeypatch, sys.executable)
    machine = keeper("echo_pkg")
    w = make_node("placed24")
    w.baseNode("count_server", namespace="robot24").basePackage("echo_pkg").machine("testbot2")
    w.reuse.action("count", type=counting.type)
    w.create()
    relayed = "action relay /robot24/placed24/base/robot24/count -> /robot24/count "
    machine.wait_line(relayed + "for ", timeout=20)
    assert counting.plain_send("/robot24/count", 4) == ("succeeded", 4, [1, 2, 3, 4])
    state, reached, _ = counting.plain_send("/robot24/count", 1000, cancel_after=2)
    assert state == "cancelled" and reached < 1000
    wait_for(lambda: "cancelled 1000" in w.base.tail(), timeout=20, what="the cancel to reach the basenode there")

    def clamp(goal, action):  # the goal changed on its way: the basenode on the robot counts to 3 at most
        return action.forward(counting.goal(min(counting.n_of(goal), 3)))

    w.new.action("count", counting.type, clamp)
    wait_for(lambda: any(relayed + "of " in line and "removed" in line for line in machine.lines), timeout=20,
             what="the keeper's relay to go")
    assert counting.plain_send("/robot24/count", 10) == ("succeeded", 3, [1, 2, 3])
    assert "goal 3" in w.base.tail()
    w.remove(action="count")
    w.reuse.action("count", type=counting.type)  # given back to the basenode, relayed on its machine again
    wait_for(lambda: sum(relayed + "for " in line for line in machine.lines) == 2, timeout=20, what="relayed again")
    assert counting.plain_send("/robot24/count", 5)[:2] == ("succeeded", 5)
    w.shutdown()
