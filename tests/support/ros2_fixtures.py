"""ROS 2 fixtures (a pytest plugin, loaded by tests/conftest.py in the ROS 2 venv): a DDS domain of the run's own.

Run with the ROS 2 venv (``bash run.sh test`` makes it): rclpy from PyPI, no ROS 1.
Each DSL node is a ROS 2 node of its own in the pytest process; peers are rclpy
scripts in ``ros2/peers/``, started and stopped by the tests.

``session``, ``make_node``, ``failures``, ``notices`` and ``peer`` are the names the
tests in ``both/`` use; ``ros1_fixtures`` gives the same on ROS 1.
"""

from __future__ import annotations

import atexit
import os
import shutil
import sys
import tempfile
from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parents[1]
PEERS = TESTS / "ros2" / "peers"

from peer import Peer as SharedPeer  # noqa: E402
from support import node_maker, wait_for  # noqa: E402,F401 - the tests import wait_for from here

from ipyros.ros2 import fastdds  # noqa: E402 - no rclpy in it

# Set before rclpy starts: the backend, a domain no other run on this machine uses, and
# discovery kept to this machine.
os.environ["IPYROS_ROS"] = "2"
os.environ["ROS_DOMAIN_ID"] = str(1 + os.getpid() % 100)  # 1..100: the ids safe on Linux
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("AMENT_PREFIX_PATH", sys.prefix)
# ROS_HOME of the run's own (basenode logs, ipyros's Fast DDS profile), removed at the end.
ROS_HOME = tempfile.mkdtemp(prefix="ipyros-ros2-test-home-")
os.environ["ROS_HOME"] = ROS_HOME
os.environ["ROS_LOG_DIR"] = os.path.join(ROS_HOME, "log")
atexit.register(shutil.rmtree, ROS_HOME, ignore_errors=True)

#: The ROS this plugin is for (the tests in both/ ask).
ROS = 2


class Peer(SharedPeer):
    """An rclpy peer process from ``ros2/peers/``."""

    PEERS = PEERS


@pytest.fixture(scope="session", autouse=True)
def fast_dds_memory_freed():
    """Fast DDS frees its shared memory when a participant is deleted; a node that crashes (some tests
    crash basenodes on purpose) leaves it in /dev/shm. What this run made and nobody uses is removed.

    Before the run, so are the Fast DDS files nobody uses that a killed process left (an earlier run
    stopped half-way, a crashed program): a stale port keeps its lock, and a new participant that is
    given that port number is never seen by the others (its node does not show up in the graph).
    """
    shm = fastdds.SHM
    fastdds.remove_stale_files()
    before = {p.name for p in shm.iterdir()} if shm.is_dir() else set()
    yield
    if shm.is_dir():
        fastdds.remove_stale_files({p.name for p in shm.iterdir() if "fastdds" in p.name} - before)


@pytest.fixture(scope="session")
def ros2_session():
    """The ipyros session of this pytest process, on ROS 2."""
    from ipyros.node import session as sessions

    session = sessions.configure(sessions.SessionConfig(start_master=False))
    assert session.backend.name == "ROS 2"
    yield session
    session.close()


@pytest.fixture
def failures(ros2_session):
    seen: list = []
    previous, ros2_session.report = ros2_session.report, seen.append
    yield seen
    ros2_session.report = previous


@pytest.fixture
def notices(ros2_session):
    """What the session tells the user on its own (a QoS mismatch, a basenode that died, ...)."""
    seen: list[str] = []
    previous, ros2_session.notice = ros2_session.notice, seen.append
    yield seen
    ros2_session.notice = previous


@pytest.fixture
def make_node(ros2_session):
    """Build rosNodes that are shut down when the test ends."""
    yield from node_maker(ros2_session)


@pytest.fixture
def session(ros2_session):
    """The run's ipyros session, by the name the tests in both/ use."""
    return ros2_session


@pytest.fixture
def caller():
    """``call(service, cls, request)`` from a context of its own, as another process would call.

    Right after discovery a reply can go out before the caller's reply reader is matched,
    and DDS drops it: the call is made again, as ROS 2 clients do, up to 5 times.
    """
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node("test_caller", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    clients: dict = {}

    def call(service: str, cls: type, request, patience: float = 3.0):
        client = clients.get(service) or clients.setdefault(service, node.create_client(cls, service))
        assert client.wait_for_service(timeout_sec=10), f"no service {service}"
        for _ in range(5):
            future = client.call_async(request)
            executor.spin_until_future_complete(future, timeout_sec=patience)
            if future.done():
                return future.result()
            client.remove_pending_request(future)
        raise AssertionError(f"no answer from {service} in 5 tries")

    yield call
    executor.shutdown()
    node.destroy_node()
    rclpy.try_shutdown(context=context)
    context.destroy()  # its participant deleted now: else its Fast DDS ports outlive the process


@pytest.fixture
def call(caller):
    """``call(service, cls, request)`` as the tests in both/ name it: :func:`caller`."""
    return caller


@pytest.fixture
def counting():
    """Count to N as an action of ROS 2 (test_msgs/Fibonacci; see support/counting.py)."""
    from counting import CountingRos2

    return CountingRos2()
