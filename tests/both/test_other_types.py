"""A peer that publishes another type on a topic a node subscribes to is told, once, naming the peer and both
types: ROS connects no two types, and says so only in a log file (ROS 1) or not at all (ROS 2)."""

from __future__ import annotations

from shell import ok
from std_msgs.msg import String
from support import wait_for


def test_a_peer_of_another_type_is_told_once(make_node, peer, notices):
    """(A type that a live topic has already is refused at the declaration; this peer comes later.)"""
    heard = []
    make_node("types_listener").new.subscribe("/types/mixed", handler=heard.append, msgType=String).create()
    talker = peer("talk.py", "/types/mixed", "geometry_msgs/Point", 5, "x=1.0")
    talker.wait_line("ready")
    told = wait_for(lambda: [n for n in notices if "/types/mixed" in n], timeout=20, what="the notice")
    assert len(told) == 1, told
    text = told[0]
    assert "/talk_peer publishes geometry_msgs/Point there" in text and "as std_msgs/String" in text, text
    assert "nothing passes between them" in text and "msgType='geometry_msgs/Point'" in text
    assert not heard


def test_topics_v_shows_each_endpoints_type(ip, make_node, peer, capsys):  # noqa: F811
    make_node("types_shown").new.subscribe("/types/shown", handler=lambda m: None, msgType=String).create()
    talker = peer("talk.py", "/types/shown", "geometry_msgs/Point", 5)
    talker.wait_line("ready")

    def shown() -> bool:
        ok(ip, "%topics -v /types/shown")
        out = capsys.readouterr().out
        return "std_msgs/String" in out and "geometry_msgs/Point" in out and "nothing passes" in out

    wait_for(shown, timeout=20, interval=0.5, what="%topics -v to show both types")


def test_topics_says_which_types_are_not_installed_and_how_to_install_them(ip, peer, capsys, monkeypatch):
    """A topic whose type this Python lacks (a workspace's own, a package not installed) is listed all the same,
    and one line says what to install (issue 24)."""
    import sys

    from ipyros.core import msgtypes

    peer("talk.py", "/nit/point", "geometry_msgs/Point", 10).wait_line("ready")
    ok(ip, "%load_ext ipyros")
    wait_for(lambda: ok(ip, "%topics /nit") and "/nit/point" in capsys.readouterr().out, timeout=20, interval=0.3,
             what="the peer's topic")
    monkeypatch.setitem(sys.modules, "geometry_msgs", None)  # as a venv without the package: the import fails
    monkeypatch.setitem(sys.modules, "geometry_msgs.msg", None)
    ok(ip, "%topics /nit")
    out = capsys.readouterr().out
    assert "/nit/point" in out, "still listed"
    assert ("ipyros: types not installed here (their topics cannot be echoed or handled in this session): "
            f"geometry_msgs/Point ({msgtypes.install_hint('geometry_msgs')})") in out, out


def test_a_type_this_python_lacks_is_relayed_where_the_transport_allows(make_node, peer, session, monkeypatch):
    """ROS 1 relays the bytes of any type: a reuse of a type the session cannot import works, advertised as its
    publisher's type; ROS 2 needs the type's class, made from the basenode's own descriptions when its package is
    not on the machine (tests/ros2/test_wrap_ros2.py), else refused in one line naming the package (issue 24)."""
    import sys
    from pathlib import Path

    import pytest

    from ipyros.core import msgtypes
    from ipyros.core.errors import MessageTypeError

    talker = Path(__file__).parent / "peers" / "talk.py"
    w = make_node("raw_wrap")
    w.baseNode(str(talker), namespace="raw_robot", args=["point", "geometry_msgs/Point", "10", "x=1.5"])
    monkeypatch.setitem(sys.modules, "geometry_msgs", None)  # as a venv without the package: the import fails
    monkeypatch.setitem(sys.modules, "geometry_msgs.msg", None)
    w.reuse.publish("point", type="geometry_msgs/Point")
    if not session.backend.relays_any_type:  # learnt from the basenode at create(), but its package is here
        with pytest.raises(MessageTypeError, match=msgtypes.install_hint("geometry_msgs")):
            w.create()
        assert w.base is None or not w.base.running, "nothing left running"
        return
    listener = peer("listen.py", "/raw_robot/point", "geometry_msgs/Point", "x", "--name=raw_ear")
    w.create()
    try:
        listener.wait_line("heard 1.5", timeout=30)
    finally:
        w.shutdown()
