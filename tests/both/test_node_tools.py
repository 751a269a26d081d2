"""%node as complete as rosnode info / ros2 node info, %node --ping and --kill, %nodes --cleanup (issue 25)."""

from __future__ import annotations

import signal

from shell import error_of, ok
from std_srvs.srv import SetBool
from support import response_of, wait_for

from ipyros.node.session import current


def graph_has(node: str) -> bool:
    return node in current().backend.graph_snapshot().nodes


def test_node_shows_services_and_actions_with_their_types_and_answers_a_ping(ip, make_node, counting, capsys):
    make_node("info_node", namespace="/info").new.service("enable", SetBool, handler=lambda r: response_of(SetBool)()) \
        .action("count", counting.type, lambda goal: None).create()
    wait_for(lambda: graph_has("/info/info_node") or graph_has(current().process.name), timeout=20,
             what="the node in the graph")
    host = "/info/info_node" if current().backend.name == "ROS 2" else current().process.name
    capsys.readouterr()
    ok(ip, f"%node {host}")
    out = capsys.readouterr().out
    assert "SetBool" in next(line for line in out.splitlines() if "/info/enable" in line), out
    row = next(line for line in out.splitlines() if "/info/count" in line and "action" in line)
    assert "action server" in row and counting.type in row, out
    assert "/info/count/" not in out, "an action's parts are one row"
    ok(ip, f"%node {host} --ping")
    assert f"{host}: answered in " in capsys.readouterr().out
    assert "this session's own" in str(error_of(ip, f"%node {host} --kill"))


def test_node_kill_ends_a_peer_on_ros1_and_is_refused_in_one_line_on_ros2(ip, peer, session, capsys):
    listener = peer("listen.py", "/kill_me/topic", "std_msgs/String", "data")
    listener.wait_line("ready")
    wait_for(lambda: graph_has("/listen_peer"), timeout=20, what="the peer in the graph")
    if session.backend.name == "ROS 2":
        assert "ROS 2 has no way to ask /listen_peer to end" in str(error_of(ip, "%node /listen_peer --kill"))
        return
    assert "managed (lifecycle) nodes are ROS 2's" in str(error_of(ip, "%lifecycle /listen_peer"))
    ok(ip, "%node /listen_peer --kill")
    assert listener.proc.wait(20) is not None


def test_nodes_cleanup_forgets_a_node_that_died_without_unregistering(ip, peer, session, capsys):
    # A name of its own: killed, it lingers in a ROS 2 graph until discovery gives up on it, and a later
    # peer of the same name would be read through it (rclpy's by-node queries take the first of a name).
    listener = peer("listen.py", "/cleanup_me/topic", "std_msgs/String", "data", "--name=cleanup_peer")
    listener.wait_line("ready")
    wait_for(lambda: graph_has("/cleanup_peer"), timeout=20, what="the peer in the graph")
    listener.proc.send_signal(signal.SIGKILL)  # no chance to unregister
    listener.proc.wait(10)
    capsys.readouterr()
    ok(ip, "%nodes --cleanup")
    out = capsys.readouterr().out
    if session.backend.name == "ROS 2":
        assert "nothing to clean up" in out  # discovery forgets it by itself
        return
    assert "forgot /cleanup_peer" in out, out
    assert not graph_has("/cleanup_peer")


def test_node_lists_its_connections_on_ros1(ip, make_node, peer, session, capsys):
    """As rosnode info: which topic connects to which node, in or out (ROS 1; DDS keeps no such list)."""
    heard = []
    make_node("conn_node").new.subscribe("/conn/chatter", lambda m: heard.append(m.data),
                                         msgType="std_msgs/String").create()
    talker = peer("talk.py", "/conn/chatter", "std_msgs/String", 20, "data='hi'")
    talker.wait_line("ready")
    wait_for(lambda: heard, timeout=20, what="the talker's messages")
    host = session.process.name if session.backend.name == "ROS 1" else "/conn_node"
    capsys.readouterr()
    ok(ip, f"%node {host}")
    rows = [line for line in capsys.readouterr().out.splitlines() if "connection" in line]
    if session.backend.name == "ROS 2":
        assert not rows
        return
    assert any("/conn/chatter" in row and "in from /talk_peer" in row and "TCPROS" in row for row in rows), rows
