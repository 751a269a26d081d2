"""Leaving many nodes costs seconds, not a minute: their basenodes are stopped side by side, on either ROS."""

from __future__ import annotations

import threading
import time
from pathlib import Path

from std_msgs.msg import UInt32
from support import children, wait_for

import ipyros
from ipyros.processes.basenode import BaseProcess

PEERS = Path(__file__).parent / "peers"


def test_shutting_several_wrapped_nodes_down_stops_their_basenodes_side_by_side(make_node, monkeypatch):
    """Each basenode is asked to stop before any has ended (one after another, 50 took most of a minute), and all
    of them and the nodes are gone afterwards."""
    stops: list[tuple[float, float]] = []
    lock = threading.Lock()
    original = BaseProcess.stop

    def timed_stop(self, timeout: float = 5.0):
        began = time.monotonic()
        try:
            return original(self, timeout)
        finally:
            with lock:
                stops.append((began, time.monotonic()))

    before = children()
    nodes = []
    for i in range(3):
        nd = make_node(f"side_by_side_{i}")
        nd.baseNode(str(PEERS / "talk.py"), name=f"side_talker_{i}", namespace=f"side{i}",
                    args=["level", "std_msgs/UInt32", "5", "data=1"])
        nd.reuse.publish("level", type=UInt32)
        nd.create()
        nodes.append(nd)
    plain = make_node("side_by_side_plain").new.publish("/side/plain", msgType=UInt32).create()
    monkeypatch.setattr(BaseProcess, "stop", timed_stop)
    ipyros.shutdown(*nodes, plain)
    assert not any(nd.created for nd in (*nodes, plain))
    assert len(stops) >= 3, stops
    assert max(began for began, _ in stops) < min(ended for _, ended in stops), \
        f"the basenodes were stopped one after another: {stops}"
    wait_for(lambda: children() <= before, what="every basenode to be gone")


def test_shutdown_of_no_node_in_particular_is_every_node_of_the_session(make_node):
    first = make_node("all_of_them_1").create()
    second = make_node("all_of_them_2").new.publish("/all_of_them", msgType=UInt32).create()
    ipyros.shutdown()
    assert not first.created and not second.created


def test_shutdown_of_something_else_is_one_line(make_node):
    import pytest

    from ipyros.core.errors import DeclarationError

    with pytest.raises(DeclarationError, match=r"shutdown\('nd'\): give rosNodes"):
        ipyros.shutdown("nd")
