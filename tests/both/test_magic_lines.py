"""Options of the magics that take free text work wherever the usage line puts them, and timeouts are kept."""

from __future__ import annotations

import threading

import pytest
from shell import error_of, ok
from std_srvs.srv import SetBool
from support import response_of, wait_for


@pytest.fixture
def slow_service(make_node):
    """/lines/slow answers only when released (the test's end); says whether it has answered yet."""
    release, answered = threading.Event(), threading.Event()

    def slow(request):
        release.wait(60)
        answered.set()
        return response_of(SetBool)(success=True, message="late")

    make_node("lines_slow").new.service("/lines/slow", SetBool, handler=slow).create()
    yield answered
    release.set()


@pytest.mark.parametrize("line", [
    "%call /lines/slow -t 1",
    "%call /lines/slow std_srvs/SetBool {data: true} -t 1",
    "%call -t 1 /lines/slow {data: true}",
    "%call /lines/slow {data: true} --timeout=1",
])
def test_call_honours_its_timeout_wherever_it_is_given(ip, slow_service, line):
    error = error_of(ip, line)
    assert "did not answer within 1 s" in str(error), error
    assert not slow_service.is_set(), "the call waited for the server's answer instead of giving up after 1 s"


def test_pub_reads_options_after_the_message(ip, peer, capsys):
    listener = peer("listen.py", "/lines/chatter", "std_msgs/String", "data")
    listener.wait_line("ready")
    with_interrupt = threading.Timer(3.0, __import__("_thread").interrupt_main)
    with_interrupt.start()
    try:
        ok(ip, "%pub /lines/chatter std_msgs/String {data: hello} -r 5")
    finally:
        with_interrupt.cancel()
    assert listener.wait_line("heard") == "heard 'hello'"
    out = capsys.readouterr().out
    assert "at 5 Hz" in out


@pytest.mark.parametrize("line", [
    "%pub /lines/bomb std_msgs/String " + "{a: &a [1,2,3,4,5,6,7,8,9], b: &b [*a,*a,*a,*a,*a,*a,*a,*a,*a], "
    "c: &c [*b,*b,*b,*b,*b,*b,*b,*b,*b], d: &d [*c,*c,*c,*c,*c,*c,*c,*c,*c], e: &e [*d,*d,*d,*d,*d,*d,*d,*d,*d], "
    "f: &f [*e,*e,*e,*e,*e,*e,*e,*e,*e], g: &g [*f,*f,*f,*f,*f,*f,*f,*f,*f], h: [*g,*g,*g,*g,*g,*g,*g,*g,*g]}",
    "%param /lines/bomb " + "{a: &a [1,2,3,4,5,6,7,8,9], b: &b [*a,*a,*a,*a,*a,*a,*a,*a,*a], "
    "c: &c [*b,*b,*b,*b,*b,*b,*b,*b,*b], d: &d [*c,*c,*c,*c,*c,*c,*c,*c,*c], e: &e [*d,*d,*d,*d,*d,*d,*d,*d,*d], "
    "f: &f [*e,*e,*e,*e,*e,*e,*e,*e,*e], g: &g [*f,*f,*f,*f,*f,*f,*f,*f,*f], h: [*g,*g,*g,*g,*g,*g,*g,*g,*g]}",
])
def test_a_yaml_alias_bomb_is_refused_at_once(ip, line, make_node):
    """Refused by counting what the aliases would expand to, before anything is built (10 million elements)."""
    make_node("lines_bomb_host").create()  # %param needs a running session
    error = error_of(ip, line)
    assert "expands to more than" in str(error) and "\n" not in str(error)


def test_a_one_shot_pub_is_not_latched_unless_asked(ip, peer, session):
    """%pub sends once, as rostopic pub -1 / ros2 topic pub --once: a subscriber that comes later does not get an
    old command (issue 25); --latch keeps it for later ones."""
    def known(topic: str, count: int) -> None:  # a one-shot %pub waits for the subscribers the graph knows
        wait_for(lambda: len(session.backend.graph_snapshot().subscribers.get(topic, ())) == count, timeout=20,
                 what=f"the graph to know {count} listener(s) of {topic}")

    first = peer("listen.py", "/lines/once", "std_msgs/String", "data")
    first.wait_line("ready")
    known("/lines/once", 1)
    ok(ip, "%pub /lines/once std_msgs/String {data: old}")
    first.wait_line("heard 'old'")
    late = peer("listen.py", "/lines/once", "std_msgs/String", "data", "--name=late_peer")
    late.wait_line("ready")
    known("/lines/once", 2)
    ok(ip, "%pub /lines/once std_msgs/String {data: marker}")
    late.wait_line("heard 'marker'")
    assert [line for line in late.lines if line.startswith("heard")][0] == "heard 'marker'", late.lines

    ok(ip, "%pub /lines/kept std_msgs/String {data: kept} --latch")
    later = peer("listen.py", "/lines/kept", "std_msgs/String", "data", "--name=later_peer", "--latched")
    later.wait_line("heard 'kept'")
