"""A %load_nodes that fails leaves the user's namespace and running nodes as they were (issue 25)."""

from __future__ import annotations

from shell import error_of, ok
from support import wait_for

from ipyros.dsl import rosNode


def test_a_failed_load_changes_no_variable_and_stops_no_node(ip, tmp_path):
    ok(ip, 'keeper = rosNode("load_keeper").new.publish("/load_keeper/out", msgType="std_msgs/String").create()')
    ok(ip, "def tick(event):\n    keeper.write('/load_keeper/out', __import__('std_msgs.msg').msg.String(data='x'))")
    ok(ip, "keeper.timer(0.2, tick)")
    running = ip.user_ns["keeper"]
    ok(ip, f"%save_nodes {tmp_path / 'kept.py'}")
    # Loading it again while it runs: the saved file's node has the running one's name.
    error = error_of(ip, f"%load_nodes {tmp_path / 'kept.py'}")
    assert "a node named /load_keeper is already running" in str(error)
    assert "keeper.shutdown()" in str(error), "the advice names the variable, as the user typed it"
    assert ip.user_ns["keeper"] is running and running.created, "the variable still holds the running node"
    before = running.status().row("tick")  # the timer, which reads keeper, goes on writing without errors
    wait_for(lambda: running.status().row("tick").calls >= before.calls + 3, timeout=10, what="three more ticks")
    assert running.status().row("tick").errors == before.errors
    assert rosNode.running("load_keeper") is running
