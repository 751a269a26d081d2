"""ROS 1 fixtures (a pytest plugin, loaded by tests/conftest.py in the ROS 1 venv): a real rosmaster.

The pytest process hosts one rospy node for the whole run (rospy allows one per
process), so the master is session-scoped. Tests that need a fresh process (exit,
SIGKILL, the IPython terminal, a Jupyter kernel) start one themselves.

``session``, ``make_node``, ``failures``, ``notices`` and ``peer`` are the names the
tests in ``both/`` use; ``ros2_fixtures`` gives the same on ROS 2.
"""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parents[1]

from helpers import free_port, one_call  # noqa: E402,F401 - the tests import free_port from here too
from peer import Peer as SharedPeer  # noqa: E402
from support import SESSION_PIDS, node_maker, wait_for  # noqa: E402,F401 - the tests import wait_for from here

from ipyros.core.model import BaseModel  # noqa: E402
from ipyros.processes.basenode import BaseProcess  # noqa: E402
from ipyros.ros1.export import RospyScript  # noqa: E402
from ipyros.ros1.graph import fetch_snapshot  # noqa: E402
from ipyros.ros1.nodes import command  # noqa: E402
from ipyros.tools.graph import GraphCache  # noqa: E402

# The test basenodes are a ROS package: found by package + executable, as rosrun finds them.
os.environ["ROS_PACKAGE_PATH"] = os.pathsep.join(
    p for p in (str(TESTS / "nodes"), os.environ.get("ROS_PACKAGE_PATH", "")) if p)
os.environ.setdefault("IPYROS_ROS", "1")

#: The ROS this plugin is for (the tests in both/ ask).
ROS = 1

#: The interpreter that runs rospy here, as exported scripts name it (the tests run exports with it).
ROS1_PYTHON = RospyScript.shebang()[2:]


def ros1_process(executable, args=(), *, master_uri=None, node_name=None, namespace=None, remaps=None, params=None,
                 **options):
    """A ROS 1 node's process, its command line written as the backend writes it (ros1/nodes.py)."""
    model = BaseModel(executable=str(executable), args=list(args), node_name=node_name,
                      namespace=namespace, remaps=dict(remaps or {}), params=dict(params or {}))
    env = {"ROS_MASTER_URI": master_uri} if master_uri else {}
    return BaseProcess(command(model), node_name=node_name, env=env, **options)


def master_graph(uri: str, **options) -> GraphCache:
    """A graph cache reading the master at ``uri``, as the ROS 1 backend gives it."""
    return GraphCache(lambda timeout: fetch_snapshot(uri, timeout), lambda: uri, **options)


class Peer(SharedPeer):
    """A rospy peer process from ``ros1/peers/``."""

    PEERS = TESTS / "ros1" / "peers"


def _master_answers(uri: str) -> bool:
    try:
        code, _, _ = one_call(uri).getPid("/pytest")
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


@pytest.fixture(scope="session")
def ros_session(ros_master):
    """The ipyros session of this pytest process, on the fixture's master.

    Its one rospy node is named /ipyros_test; every DSL node of the run lives in it.
    """
    from ipyros.node import session as sessions

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


@pytest.fixture
def session(ros_session):
    """The run's ipyros session, by the name the tests in both/ use."""
    return ros_session


@pytest.fixture
def notices(ros_session):
    """What the session tells the user on its own (a basenode that died, a peer of another type, ...)."""
    seen: list[str] = []
    previous, ros_session.notice = ros_session.notice, seen.append
    yield seen
    ros_session.notice = previous


def master_state(uri: str) -> dict:
    """{'pub': {topic: [nodes]}, 'sub': {...}, 'srv': {...}} straight from the master."""
    code, _, (pubs, subs, srvs) = one_call(uri).getSystemState("/pytest")
    return {"pub": dict(pubs), "sub": dict(subs), "srv": dict(srvs)}


@pytest.fixture
def call(ros_session):
    """``call(service, cls, request)``: a plain rospy client's call; its response (a ServiceException on error)."""
    import rospy

    def call(service: str, cls: type, request):
        rospy.wait_for_service(service, timeout=10)
        proxy = rospy.ServiceProxy(service, cls)
        try:
            return proxy(request)
        finally:
            proxy.close()

    return call


@pytest.fixture
def counting(ros_session):
    """Count to N as an action of ROS 1 (actionlib/Test; see support/counting.py); its client runs in
    this process's rospy node, started here if no test has yet."""
    from counting import CountingRos1

    if not ros_session.process.started:
        ros_session.start_process_node("/counting_client")
    return CountingRos1()


@pytest.fixture(scope="module")
def no_ipyros(tmp_path_factory) -> Path:
    """A PYTHONPATH entry whose ``ipyros`` fails to import: the exported processes run with it."""
    root = tmp_path_factory.mktemp("no_ipyros")
    (root / "ipyros").mkdir()
    (root / "ipyros" / "__init__.py").write_text('raise ImportError("an exported node must run without ipyros")\n')
    return root
