"""How a session ends: SIGTERM and SIGHUP as clean as Ctrl-C, and nodes stopped before IPython's namespace goes."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from helpers import one_call
from ros1_fixtures import master_state, wait_for

SESSION = """
from ipyros import rosNode
from std_msgs.msg import String
nd = rosNode("terminated_user")
nd.baseNode("echo_node").basePackage("ipyros_test_nodes")
nd.reuse.subscribe("in", type=String).publish("out", type=String)
nd.new.publish("/terminated/extra", msgType=String)
nd.create()
relay = rosNode("terminated_relay")
relay.baseNode("relay", args=["/terminated/a", "/terminated/b"]).basePackage("topic_tools")
relay.reuse.subscribe("/terminated/a", type=String)
relay.create()
print("READY", flush=True)
import time
while True:
    time.sleep(1)
"""


def registered(uri: str, node: str) -> bool:
    code, _, _ = one_call(uri).lookupNode("/pytest", node)
    return code == 1


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGHUP], ids=["SIGTERM", "SIGHUP"])
def test_a_terminating_signal_unregisters_everything(ros_master, signum):
    proc = subprocess.Popen([sys.executable, "-c", SESSION], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env={**os.environ, "ROS_MASTER_URI": ros_master})
    try:
        line = proc.stdout.readline()
        assert line.strip() == "READY", proc.stderr.read() if proc.poll() is not None else line
        nodes = ["/terminated_user", "/echo_node", "/relay"]
        assert all(registered(ros_master, n) for n in nodes)
        proc.send_signal(signum)
        assert proc.wait(30) == -signum, "it dies of the signal, as a process killed so should"
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    for node in nodes:
        assert not registered(ros_master, node), f"{node} is left on the master as a dead entry"
    state = master_state(ros_master)
    assert "/terminated/extra" not in state["pub"] and "/terminated/a" not in state["sub"]


def test_exit_stops_the_nodes_before_the_namespace_is_cleared(ros_master, tmp_path):
    """The terminal's mainloop clears the user namespace before atexit: handlers must be stopped first."""
    cells = textwrap.dedent("""\
        from std_msgs.msg import String
        speed = 4.5
        seen = []
        def tick():
            seen.append(speed)
        nd = rosNode("exiting_terminal")
        nd.timer(0.002, tick)
        nd.create()
        import time; time.sleep(0.5); print("TICKS", len(seen) > 10)
        import atexit; atexit.register(time.sleep, 0.5)  # runs before ipyros's own exit hook: a window
        exit
        """)
    ipython = Path(sys.executable).with_name("ipython")
    result = subprocess.run([str(ipython), "--simple-prompt", "--ext", "ipyros", "--no-banner",
                             "--HistoryManager.hist_file=:memory:"], input=cells, capture_output=True,
                            text=True, timeout=60, env={**os.environ, "ROS_MASTER_URI": ros_master},
                            cwd=tmp_path)
    assert "TICKS True" in result.stdout, result.stdout + result.stderr
    assert "NameError" not in result.stdout + result.stderr, result.stderr
    assert result.returncode == 0, result.stderr
    wait_for(lambda: not registered(ros_master, "/exiting_terminal"), what="the node to unregister")


def test_exit_after_the_master_died_is_quiet(tmp_path, ros_home):
    """The master went away first: leaving must not print rospy's warning once per endpoint it cannot unregister."""
    from ros1_fixtures import free_port
    from topic_nodes import stop

    port = free_port()
    uri = f"http://127.0.0.1:{port}/"
    master = subprocess.Popen(["rosmaster", "--core", "-p", str(port), "-w", "3"], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)
    try:
        wait_for(lambda: _answers(uri), timeout=20, what="the master to answer")
        cells = textwrap.dedent("""\
            from std_msgs.msg import String
            nd = rosNode("orphaned")
            for i in range(5): nd.new.publish(f"/orphan/t{i}", msgType=String)
            nd.new.subscribe("/orphan/in", print, msgType=String)
            nd.create(); print("CREATED")
            import os, signal, time; os.kill(int(os.environ["MASTER_PID"]), signal.SIGTERM)
            from ipyros.ros1.master import answers
            while answers(os.environ["ROS_MASTER_URI"], 0.2): time.sleep(0.05)
            exit
            """)
        ipython = Path(sys.executable).with_name("ipython")
        result = subprocess.run([str(ipython), "--simple-prompt", "--ext", "ipyros", "--no-banner",
                                 "--HistoryManager.hist_file=:memory:"], input=cells, capture_output=True, text=True,
                                timeout=60, env={**os.environ, "ROS_MASTER_URI": uri, "MASTER_PID": str(master.pid)},
                                cwd=tmp_path)
        said = result.stdout + result.stderr
        assert "CREATED" in said and result.returncode == 0, said
        assert "unable to communicate" not in said and "[WARN]" not in said, said
    finally:
        stop(master)


def _answers(uri: str) -> bool:
    try:
        return one_call(uri).getPid("/pytest")[0] == 1
    except OSError:
        return False
