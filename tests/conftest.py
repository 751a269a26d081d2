"""Shared fixtures: a real rosmaster on a free port, and a guard against leftover processes.

The pytest process hosts one rospy node for the whole run (rospy allows one per
process), so the master is session-scoped. Tests that need a fresh process (exit,
SIGKILL, the IPython terminal, a Jupyter kernel) start one themselves.
"""

from __future__ import annotations

import atexit
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import xmlrpc.client
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))  # tests/helpers.py

from support import node_maker, wait_for  # noqa: E402,F401 - the tests import wait_for from here
# The test basenodes are a ROS package: found by package + executable, as rosrun finds them.
os.environ["ROS_PACKAGE_PATH"] = os.pathsep.join(
    p for p in (str(HERE / "nodes"), os.environ.get("ROS_PACKAGE_PATH", "")) if p)


# The session history files of the run go to a directory of its own, removed at the end.
HISTORY_DIR = tempfile.mkdtemp(prefix="ipyros-test-history-")
os.environ["IPYROS_HISTORY_DIR"] = HISTORY_DIR
atexit.register(shutil.rmtree, HISTORY_DIR, ignore_errors=True)


# Processes that live for the whole run (the master): not leftovers of any one test.
SESSION_PIDS: set[int] = set()


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _master_answers(uri: str) -> bool:
    try:
        code, _, _ = xmlrpc.client.ServerProxy(uri).getPid("/pytest")
        return code == 1
    except OSError:
        return False


@pytest.fixture(scope="session")
def ros_home(tmp_path_factory) -> Path:
    home = tmp_path_factory.mktemp("ros_home")
    os.environ["ROS_HOME"] = str(home)
    os.environ["ROS_LOG_DIR"] = str(home / "log")
    return home


@pytest.fixture(scope="session")
def ros_master(ros_home):
    """A rosmaster of our own on a free port; ROS_MASTER_URI points at it for the run."""
    port = free_port()
    uri = f"http://127.0.0.1:{port}/"
    proc = subprocess.Popen(
        ["rosmaster", "--core", "-p", str(port), "-w", "3"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env={**os.environ, "ROS_MASTER_URI": uri},
    )
    SESSION_PIDS.add(proc.pid)
    try:
        wait_for(lambda: _master_answers(uri), timeout=20, what="rosmaster to answer")
        os.environ["ROS_MASTER_URI"] = uri
        os.environ["ROS_IP"] = "127.0.0.1"
        os.environ.pop("ROS_HOSTNAME", None)
        yield uri
    finally:
        from topic_nodes import stop

        stop(proc)


def _children() -> set[int]:
    """PIDs of this process's living children (zombies and session processes excluded)."""
    out = set()
    kids: list[str] = []
    for task in Path(f"/proc/{os.getpid()}/task").iterdir():  # children of every thread
        try:
            kids += (task / "children").read_text().split()
        except OSError:
            pass
    for pid in map(int, kids):
        if pid in SESSION_PIDS:
            continue
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if state != "Z":
            out.add(pid)
    return out


@pytest.fixture(autouse=True)
def no_leftover_processes(request):
    """Fail a test that leaves a child process of its own running."""
    before = _children()
    yield
    try:
        wait_for(lambda: not (_children() - before), timeout=10, what="children to exit")
    except AssertionError:
        left = {pid: Path(f"/proc/{pid}/cmdline").read_text().replace("\0", " ") for pid in _children() - before}
        pytest.fail(f"test left processes running: {left}")


@pytest.fixture(scope="session")
def ros_session(ros_master):
    """The ipyros session of this pytest process, on the fixture's master.

    Its one rospy node is named /ipyros_test; every DSL node of the run lives in it.
    """
    from ipyros import session as sessions

    session = sessions.configure(sessions.SessionConfig(
        master_uri=ros_master, start_master=False, process_node_name="/ipyros_test"))
    yield session
    session.close()


@pytest.fixture
def failures(ros_session):
    """Handler failures reported during the test (instead of printed)."""
    seen: list = []
    previous = ros_session.report
    ros_session.report = seen.append
    yield seen
    ros_session.report = previous


@pytest.fixture
def make_node(ros_session):
    """Build rosNodes that are shut down when the test ends."""
    yield from node_maker(ros_session)


def master_state(uri: str) -> dict:
    """{'pub': {topic: [nodes]}, 'sub': {...}, 'srv': {...}} straight from the master."""
    code, _, (pubs, subs, srvs) = xmlrpc.client.ServerProxy(uri).getSystemState("/pytest")
    return {"pub": dict(pubs), "sub": dict(subs), "srv": dict(srvs)}
