"""No handler, service or chain of declarations can stall or stop a session, on either ROS."""

from __future__ import annotations

import threading
import time

import pytest
from std_msgs.msg import UInt32
from std_srvs.srv import SetBool
from support import request_of, response_of, wait_for

from ipyros.core import errors
from ipyros.dsl import engine_of


def counting(make_node, name: str, topic: str):
    """A node that counts what it hears on ``topic``, and a talker that writes there; (seen, talker)."""
    seen: list[int] = []
    make_node(f"{name}_listener").new.subscribe(topic, handler=lambda m: seen.append(m.data), msgType=UInt32).create()
    talker = make_node(f"{name}_talker").new.publish(topic, msgType=UInt32).create()
    wait_for(lambda: any(f.connections for f in engine_of(talker).sent()), timeout=20, what="the talker to connect")
    return seen, talker


@pytest.mark.parametrize("error", [SystemExit, KeyboardInterrupt, GeneratorExit])
def test_a_handler_raising_a_base_exception_is_a_handler_error_and_the_session_goes_on(make_node, failures, error):
    seen, talker = counting(make_node, f"base_{error.__name__.lower()}", f"/resilience/{error.__name__}")
    calls = []

    def bad(msg):
        calls.append(msg.data)
        raise error("from the handler")

    bad_node = make_node(f"bad_{error.__name__.lower()}")
    bad_node.new.subscribe(f"/resilience/{error.__name__}", handler=bad, msgType=UInt32).create()
    topic = f"/resilience/{error.__name__}"
    wait_for(lambda: talker.write(topic, UInt32(data=0)) or (seen and calls), interval=0.2, timeout=20,
             what="both subscriptions to hear the talker")
    for i in range(1, 4):
        talker.write(topic, UInt32(data=i))
        wait_for(lambda: i in seen and i in calls, what=f"message {i} to both handlers")
    assert failures and isinstance(failures[0].error, error), failures
    assert bad_node.status().row(topic).errors == len(calls)
    assert {1, 2, 3} <= set(seen)


def test_a_slow_service_stalls_no_subscription(make_node, call):
    seen, talker = counting(make_node, "slow_service", "/resilience/during_service")
    started, release = threading.Event(), threading.Event()

    def slow(request):
        started.set()
        release.wait(10)
        return response_of(SetBool)(success=True, message="slow")

    make_node("slow_server").new.service("/resilience/slow", SetBool, handler=slow).create()
    answer: list = []
    caller = threading.Thread(target=lambda: answer.append(call("/resilience/slow", SetBool,
                                                                request_of(SetBool)(data=True))))
    caller.start()
    try:
        assert started.wait(20), "the service was not called"
        before = len(seen)
        for i in range(5):
            talker.write("/resilience/during_service", UInt32(data=i))
        wait_for(lambda: len(seen) >= before + 5, what="messages handled while the service handler blocks")
    finally:
        release.set()
        caller.join(20)
    assert answer and answer[0].message == "slow"


def test_a_slow_handler_holds_up_no_other_handler(make_node, notices, session):
    """ROS 1 runs each subscription on a thread of its own; ROS 2 runs every callback on one executor thread,
    and moves a handler that took long to a thread of its own (saying so)."""
    seen, talker = counting(make_node, "slow_handler", "/resilience/quick")
    gate = threading.Event()
    slow_calls = []

    def slow(msg):
        slow_calls.append(msg.data)
        gate.wait(5)

    make_node("slow_sub").new.subscribe("/resilience/slow_in", handler=slow, msgType=UInt32).create()
    feeder = make_node("slow_feeder").new.publish("/resilience/slow_in", msgType=UInt32).create()
    wait_for(lambda: engine_of(feeder).sent()[0].connections, timeout=20, what="the slow subscription to connect")
    try:
        feeder.write("/resilience/slow_in", UInt32(data=1))  # blocks until the gate opens or 5 s pass
        wait_for(lambda: slow_calls, what="the slow handler to start")
        time.sleep(0.3)  # let it be slow: past the executor's patience for a handler (ROS 2)
        gate.set()
        gate.clear()
        feeder.write("/resilience/slow_in", UInt32(data=2))  # now on a thread of its own (ROS 2)
        wait_for(lambda: len(slow_calls) == 2, what="the second call of the slow handler")
        for i in range(5):
            talker.write("/resilience/quick", UInt32(data=i))
        wait_for(lambda: len(seen) >= 5, timeout=3, what="the quick handler, while the slow one blocks")
    finally:
        gate.set()
    if session.backend.name == "ROS 2":
        assert any("/resilience/slow_in" in n and "runs on a thread of its own" in n for n in notices), notices


@pytest.mark.parametrize("where", ["another node", "the same node"])
def test_a_handler_that_blocks_on_its_first_message_holds_up_no_other_from_then_on(make_node, notices, session,
                                                                                      where):
    """A handler blocked from its first call on (a sleep, a slow service call) leaves the others running: on ROS 2
    the executor thread it holds is noticed within about a tenth of a second and replaced; the blocked call
    ends where it is, and its next calls come after it, in order."""
    tag = where.split()[0]
    gate, slow_calls, quick = threading.Event(), [], []

    def slow(msg):
        slow_calls.append(msg.data)
        gate.wait(6)

    blocked = make_node(f"blocked_{tag}")
    blocked.new.subscribe(f"/first_block/{tag}/slow", handler=slow, msgType=UInt32)
    other = blocked if where == "the same node" else make_node(f"unblocked_{tag}")
    other.new.subscribe(f"/first_block/{tag}/quick", handler=lambda m: quick.append(m.data), msgType=UInt32)
    blocked.create()
    other.create()
    feeder = make_node(f"first_block_feeder_{tag}").new.publish(f"/first_block/{tag}/slow", msgType=UInt32) \
        .publish(f"/first_block/{tag}/quick", msgType=UInt32).create()
    wait_for(lambda: all(f.connections for f in engine_of(feeder).sent()), timeout=20, what="both to connect")
    try:
        feeder.write(f"/first_block/{tag}/slow", UInt32(data=1))
        wait_for(lambda: slow_calls, what="the slow handler to start")
        feeder.write(f"/first_block/{tag}/slow", UInt32(data=2))  # waits behind the first call
        start = time.monotonic()
        for i in range(20):  # 20 Hz for 1 s, while the first call still blocks
            feeder.write(f"/first_block/{tag}/quick", UInt32(data=i))
            time.sleep(0.05)
        wait_for(lambda: len(quick) >= 15, timeout=3, what="the quick handler while the slow one blocks")
        assert not gate.is_set() and time.monotonic() - start < 5, "the slow handler was meant to block throughout"
        assert slow_calls == [1], slow_calls  # the second waits for the first: in order, never beside it
    finally:
        gate.set()
    wait_for(lambda: slow_calls == [1, 2], what="the second call after the first ended")
    if session.backend.name == "ROS 2":
        assert any(f"/first_block/{tag}/slow has held the session's executor" in n for n in notices), notices


def test_a_chain_that_fails_part_way_changes_nothing(make_node):
    nd = make_node("chain_all_or_nothing").create()
    before = nd.model()
    with pytest.raises(errors.MessageTypeError) as caught:
        nd.new.subscribe("/chain/a", handler=lambda m: None, msgType=UInt32).publish("/chain/b", msgType="nope/Nope")
    text = str(caught.value)
    assert "new.publish('/chain/b') (call 2 of the chain) failed" in text, text
    assert "new.subscribe /chain/a [std_msgs/UInt32]" in text and "were undone" in text and "\n" not in text
    assert nd.model() == before
    assert nd.handler("/chain/a") is None
    nd.new.subscribe("/chain/a", handler=lambda m: None, msgType=UInt32)  # a new chain works
    assert nd.model().topic("/chain/a", "subscribe") is not None


def test_a_chain_that_fails_before_create_changes_nothing_either(make_node):
    nd = make_node("chain_declared")
    with pytest.raises(errors.IpyrosError, match="call 3 of the chain"):
        nd.new.publish("/chain/x", msgType=UInt32).publish("/chain/y", msgType=UInt32).subscribe("/chain/z")
    assert nd.model().topics == []


SLOW_START = """
import runpy, sys, time
time.sleep(2.5)  # a basenode that takes its time before it is a node (a map to load, a crowded graph)
sys.path.insert(0, {peers!r})
sys.argv = [{talk!r}] + sys.argv[1:]
runpy.run_path({talk!r}, run_name="__main__")
"""


def test_a_basenode_slow_to_show_up_is_waited_for_and_said(make_node, notices, monkeypatch, tmp_path):
    """A running basenode that is slow to appear in the graph is waited for (not failed after a few seconds), and
    the wait is said at the prompt with how to stop it; the wrapping node then runs."""
    from pathlib import Path

    from ipyros.node import basestart

    peers = Path(__file__).parent / "peers"
    script = tmp_path / "slow_talker.py"
    script.write_text(SLOW_START.format(peers=str(peers), talk=str(peers / "talk.py")))
    monkeypatch.setattr(basestart, "SLOW_START_NOTICE", 0.5)
    w = make_node("slow_wrap")
    w.baseNode(str(script), name="talk_peer", namespace="slow_robot", args=["level", "std_msgs/UInt32", "10",
                                                                            "data=7"])
    w.reuse.publish("level", type=UInt32)
    heard: list[int] = []
    make_node("slow_listener").new.subscribe("/slow_robot/level", handler=lambda m: heard.append(m.data),
                                             msgType=UInt32).create()
    w.create()
    said = [n for n in notices if "not in the graph yet" in n]
    assert said == [f"ipyros: basenode /slow_robot/talk_peer of slow_wrap runs but is not in the graph yet; waiting "
                    f"up to {basestart.REGISTRATION_TIMEOUT:g} s (Ctrl-C stops it and slow_wrap)"], notices
    wait_for(lambda: 7 in heard, timeout=30, what="the slow basenode's messages through the relay")
    w.shutdown()


def wrapping_no_node(make_node, tmp_path, name: str):
    """``{name}_wrap`` wrapping ``{name}_base``: a process that runs but is no ROS node, so never shows up."""
    script = tmp_path / f"{name}_not_a_node.py"
    script.write_text("import time\nprint('up', flush=True)\ntime.sleep(600)\n")
    w = make_node(f"{name}_wrap")
    w.baseNode(str(script), name=f"{name}_base")
    w.reuse.publish("level", type=UInt32)
    return w


def test_a_basenode_that_runs_but_never_shows_up_fails_create_in_one_line_and_is_stopped(make_node, monkeypatch,
                                                                                      tmp_path):
    """A basenode that is no ROS node (or takes another name than it is given) is stopped once the wait ends, and
    create() says so in one line; nothing of the wrapping node is left running."""
    from support import children

    from ipyros.node import basestart

    monkeypatch.setattr(basestart, "REGISTRATION_TIMEOUT", 2.0)
    w = wrapping_no_node(make_node, tmp_path, "absent")
    before = children()
    with pytest.raises(errors.BaseNodeError) as caught:
        w.create()
    message = str(caught.value)
    assert "\n" not in message and message.startswith(
        "basenode /absent_base of absent_wrap ran 2 s without showing up in the graph ("), message
    question = "so it was stopped; is it a ROS node that keeps the name it is given?"
    hint = message.partition(question)[2]  # if the graph holds a node of a name like it (pure test: test_basestart)
    assert question in message and (not hint or hint.startswith(" nodes of a name like it: ")), message
    assert not w.created and w.base is None
    assert children() <= before, "the basenode was stopped"


def test_ctrl_c_while_create_waits_for_a_basenode_ends_it_in_one_line_with_nothing_left(make_node, notices,
                                                                                        monkeypatch, tmp_path):
    """Ctrl-C at the prompt while create() waits for a basenode that runs but never shows up: one line (not a
    traceback from inside the wait), the basenode stopped, the wrapping node not running and declared as before."""
    import _thread

    from support import children

    from ipyros.node import basestart

    monkeypatch.setattr(basestart, "SLOW_START_NOTICE", 0.3)
    w = wrapping_no_node(make_node, tmp_path, "interrupted")
    declared = w.model()
    before = children()

    def press_ctrl_c_once_said():
        wait_for(lambda: any("not in the graph yet" in n for n in notices), timeout=20, what="the wait to be said")
        _thread.interrupt_main()

    presser = threading.Thread(target=press_ctrl_c_once_said)
    presser.start()
    started = time.monotonic()
    try:
        with pytest.raises(errors.BaseNodeError) as caught:
            w.create()
    finally:
        presser.join(30)
    message = str(caught.value)
    assert time.monotonic() - started < 15, "Ctrl-C ended the wait at once"
    assert "\n" not in message and message.startswith(
        "Ctrl-C while waiting for basenode /interrupted_base of interrupted_wrap to show up in the graph: "), message
    assert "nothing is left half-declared" in message, message
    assert caught.value.__cause__ is None and caught.value.__suppress_context__, "no traceback from inside the wait"
    assert not w.created and w.base is None and w.model() == declared
    wait_for(lambda: children() <= before, what="the basenode to be stopped")


SLOW_TO_STOP = """
import pathlib, signal, sys, time
def stop(*_):
    pathlib.Path(sys.argv[1]).write_text("asked")
    time.sleep(1.5)  # a driver parking its motors before it exits
    sys.exit(0)
signal.signal(signal.SIGINT, stop)
print("up", flush=True)
time.sleep(600)
"""

INTERRUPTED_SESSION = """
import _thread, threading, time
from std_msgs.msg import UInt32
from ipyros import rosNode
from ipyros.node import basestart, session
basestart.SLOW_START_NOTICE = 0.2
session.current().notify = lambda text: (print(text, flush=True),
                                         "not in the graph yet" in text and _thread.interrupt_main())
w = rosNode("terminated_wrap")
w.baseNode({base!r}, name="terminated_base", args=[{marker!r}])
w.reuse.publish("level", type=UInt32)
try:
    w.create()
except Exception as error:
    print("CREATE", error, flush=True)
while True:
    time.sleep(1)
"""


def test_sigterm_while_an_interrupted_create_stops_its_basenode_ends_the_session_at_once(session, tmp_path):
    """Ctrl-C during create(), then SIGTERM while create() is stopping the basenode (which takes 1.5 s to park): the
    session dies of the signal once the basenode stopped, not after the 10 s deadline of a lock held by the
    interrupted main thread; nothing is left running."""
    import os
    import signal
    import subprocess
    import sys

    from helpers import pid_alive

    marker = tmp_path / "asked"
    base = tmp_path / "slow_to_stop.py"
    base.write_text(SLOW_TO_STOP)
    script = tmp_path / "session.py"
    script.write_text(INTERRUPTED_SESSION.format(base=str(base), marker=str(marker)))
    proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        wait_for(marker.exists, timeout=60, what="create() interrupted, stopping the basenode")
        pids = [int(p) for task in os.listdir(f"/proc/{proc.pid}/task")  # the basenode: a child of the session
                for p in open(f"/proc/{proc.pid}/task/{task}/children").read().split()]
        assert pids, "the basenode runs"
        terminated = time.monotonic()
        proc.send_signal(signal.SIGTERM)
        code = proc.wait(30)
        took = time.monotonic() - terminated
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        out = proc.stdout.read()
        proc.stdout.close()
    assert code == -signal.SIGTERM, out
    assert took < 8, f"died {took:.1f} s after SIGTERM: {out}"  # the basenode's 1.5 s, and closing; was 10 s
    assert not any(pid_alive(pid) for pid in pids), "the basenode was stopped"
