"""The test suite's layers, and what every test shares.

The folders are the layers, each run where it can run:

* ``unit/``: no ROS at all (the model, the plan, names, messages built from data, the
  completion line parser, ...): runs in seconds in a venv without ROS (``bash run.sh unit``);
  a module's tests are ``unit/<layer>/test_<module>.py`` (``unit/core/test_plan.py``; every module of
  ``ipyros/core/`` has one; ``unit/test_layers.py`` checks the mirror), messages of both ROS's shapes come
  from ``unit/msgpkgs/``;
* ``both/``: the DSL's behaviour, one source run on each ROS: in the ROS 1 venv against a
  rosmaster of the run's own, in the ROS 2 venv in a DDS domain of the run's own;
* ``ros1/`` and ``ros2/``: what exists on one ROS only, or is checked there in its own way.

Which ROS a run has is what its interpreter can import (the venvs ``run.sh`` makes hold one
each); the layers it cannot run are not collected. The fixtures of each ROS are in
``support/ros1_fixtures.py`` and ``support/ros2_fixtures.py``; both give the same names
(``session``, ``make_node``, ``failures``, ``notices``, ``peer``) to the tests in ``both/``.
"""

from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "support"))


def _ros_here() -> int | None:
    """The ROS this interpreter runs: 1 (rospy), 2 (rclpy), None (neither: the unit layer only)."""
    wanted = os.environ.get("IPYROS_ROS", "")
    has1, has2 = importlib.util.find_spec("rospy") is not None, importlib.util.find_spec("rclpy") is not None
    if wanted == "2" and has2 or has2 and not has1:
        return 2
    return 1 if has1 else None


ROS = _ros_here()
collect_ignore = [layer for layer, runs in (("ros1", ROS == 1), ("ros2", ROS == 2), ("both", ROS is not None))
                  if not runs]
# Fixtures by name in every test that may use them (``ip``: an IPython shell with ipyros loaded).
if ROS == 1:
    pytest_plugins = ["ros1_fixtures", "shell", "kernels"]
elif ROS == 2:
    pytest_plugins = ["ros2_fixtures", "shell"]


@pytest.fixture(scope="session", autouse=True)
def history_dir(tmp_path_factory):
    """The session history files of the run, in pytest's own temporary directory: gone with it, even after a
    run that was killed (a directory of ours in /tmp would stay)."""
    os.environ["IPYROS_HISTORY_DIR"] = str(tmp_path_factory.mktemp("history"))
    yield
    os.environ.pop("IPYROS_HISTORY_DIR", None)



@pytest.fixture(autouse=True)
def no_leftover_processes():
    """Fail a test that leaves a child process of its own running."""
    from support import children, wait_for

    before = children()
    yield
    try:
        wait_for(lambda: not (children() - before), timeout=10, what="children to exit")
    except AssertionError:
        left = {pid: Path(f"/proc/{pid}/cmdline").read_text().replace("\0", " ") for pid in children() - before}
        pytest.fail(f"test left processes running: {left}")


@pytest.fixture
def peer():
    """Start peers from ``both/peers/`` (plain ROS nodes on whichever ROS the run has), stopped after the test:
    ``listener = peer("listen.py", "/topic", "geometry_msgs/Twist", "linear.x")``."""
    from peer import Peer, stop_together

    class BothPeer(Peer):
        PEERS = HERE / "both" / "peers"

    started: list[Peer] = []

    def start(script: str, *args: object) -> Peer:
        started.append(BothPeer(script, *map(str, args)))
        return started[-1]

    yield start
    stop_together(started)
