"""The master (found or started), and what the interpreter's exit stops: in fresh processes."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest
from ros1_fixtures import free_port, master_state, wait_for

from ipyros.core.errors import MasterError
from ipyros.ros1 import master as masters


def run_python(code: str, env: dict, timeout: float = 60) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], env={**os.environ, **env},
                          capture_output=True, text=True, timeout=timeout)


def test_a_running_master_is_used_as_is(ros_master):
    handle = masters.attach(ros_master)
    assert not handle.started and handle.uri == ros_master
    assert "found running" in handle.describe()


def test_no_master_and_starting_disallowed_is_a_clear_error(ros_master):
    uri = f"http://127.0.0.1:{free_port()}/"
    with pytest.raises(MasterError, match=f"no ROS master answers at {uri}; start roscore there, or allow"):
        masters.attach(uri, start=False)
    os.environ["ROS_MASTER_URI"] = ros_master  # attach() points the environment at what it uses


def test_an_embedded_master_is_started_used_and_stopped_at_exit(ros_home):
    uri = f"http://localhost:{free_port()}/"
    result = run_python("""
        from ipyros import rosNode
        from std_msgs.msg import String
        nd = rosNode("embedded_user").create()
        nd.new.publish("/embedded/out", msgType=String)
        import xmlrpc.client, os
        state = xmlrpc.client.ServerProxy(os.environ["ROS_MASTER_URI"]).getSystemState("/t")[2]
        print("PUBS", dict(state[0]).get("/embedded/out"))
    """, {"ROS_MASTER_URI": uri})
    assert result.returncode == 0, result.stderr
    assert f"ipyros: ROS master {uri} (started by ipyros, local: listening on 127.0.0.1 only; it stops when this " \
           "session exits)" in result.stderr
    assert "PUBS ['/embedded_user']" in result.stdout
    assert not masters.answers(uri), "the embedded master must stop when the interpreter exits"


def listening(pid: int) -> set[str]:
    """The addresses ``pid`` listens on (TCP), as ``address:port``."""
    out = subprocess.run(["ss", "-ltnpH"], capture_output=True, text=True, check=True).stdout
    return {line.split()[3] for line in out.splitlines() if f"pid={pid}," in line}


def test_an_embedded_master_and_what_it_starts_listen_on_loopback_only(ros_home):
    uri = f"http://localhost:{free_port()}/"
    env = {k: v for k, v in os.environ.items() if k not in ("ROS_IP", "ROS_HOSTNAME")}
    code = textwrap.dedent("""
        import os, subprocess, sys
        from ipyros import rosNode
        from ipyros.node.session import current
        from std_msgs.msg import String
        w = rosNode("loopback_wrapper")
        w.baseNode("echo_node").basePackage("ipyros_test_nodes").reuse.publish("out", type=String)
        w.create()
        pids = [os.getpid(), w.base.pid] + [p.pid for p in current().backend.connection.master.processes]
        print("PIDS", *pids, flush=True)
        sys.stdin.read()
    """)
    proc = subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env={**env, "ROS_MASTER_URI": uri})
    try:
        line = proc.stdout.readline()
        assert line.startswith("PIDS"), proc.stderr.read() if proc.poll() is not None else line
        pids = [int(p) for p in line.split()[1:]]
        assert len(pids) == 4  # this session, the basenode, rosmaster, rosout
        for pid in pids:
            addresses = wait_for(lambda: listening(pid), what=f"pid {pid} to listen")
            assert all(a.startswith("127.0.0.1:") for a in addresses), (pid, open(f"/proc/{pid}/cmdline").read(), addresses)
    finally:
        proc.stdin.close()
        proc.wait(30)


def test_exit_stops_the_nodes_of_the_session(ros_master):
    result = run_python("""
        from ipyros import rosNode
        from std_msgs.msg import String
        nd = rosNode("exiting_user")
        nd.new.publish("/exiting/out", msgType=String).subscribe("/exiting/in", handler=print, msgType=String)
        nd.timer(0.01, lambda: None)
        nd.create()
        print("up", flush=True)
    """, {"ROS_MASTER_URI": ros_master})
    assert result.returncode == 0, result.stderr
    assert "up" in result.stdout
    wait_for(lambda: "/exiting/out" not in master_state(ros_master)["pub"]
             and "/exiting/in" not in master_state(ros_master)["sub"], what="the exiting node to unregister")


def test_a_name_taken_by_a_live_node_is_refused(ros_master):
    from peer import Peer

    with Peer("publish_type.py", "/taken/topic", "std_msgs/String", "__name:=taken_name") as peer:
        peer.wait_line("ready")
        result = run_python("""
            from ipyros import rosNode
            from ipyros.core.errors import NodeStateError
            try:
                rosNode("taken_name").create()
            except NodeStateError as e:
                print("ERR", e)
        """, {"ROS_MASTER_URI": ros_master})
        assert "ERR a node named /taken_name is already running; give this node another name" in result.stdout
        assert peer.proc.poll() is None, "the other node must not have been shut down"
