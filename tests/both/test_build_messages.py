"""A workspace's own message package made importable at the prompt with one call (issue 24), here and for the
processes started after: ROS 1 builds it with genpy, ROS 2 with the rosidl generators from PyPI and the C compiler."""

from __future__ import annotations

import contextlib
import os
import sys
import time

import pytest
from support import wait_for

from ipyros import build_messages
from ipyros.core.errors import MessageTypeError


def write_package(root):
    package = root / "ws_status_msgs"
    (package / "msg").mkdir(parents=True)
    (package / "srv").mkdir()
    (package / "package.xml").write_text("<package format='2'><name>ws_status_msgs</name></package>\n")
    (package / "msg" / "RobotStatus.msg").write_text("# what the robot says of itself\nstd_msgs/Header header\nstring mode\n"
                                                     "float64 battery\ngeometry_msgs/Point where\nuint8 IDLE=0\n")
    (package / "srv" / "SetMode.srv").write_text("string mode\n---\nbool ok\nRobotStatus status\n")
    return package


def test_a_message_package_is_built_and_used_by_the_session_and_its_peers(session, make_node, peer, tmp_path,
                                                                          monkeypatch):
    package = write_package(tmp_path)
    monkeypatch.setattr(sys, "path", list(sys.path))  # what the build adds is taken back after the test
    monkeypatch.setenv("PYTHONPATH", os.environ.get("PYTHONPATH", ""))
    monkeypatch.setenv("LD_LIBRARY_PATH", os.environ.get("LD_LIBRARY_PATH", ""))  # ROS 2's type support libraries
    assert build_messages(package, tmp_path / "built") == ["ws_status_msgs/RobotStatus", "ws_status_msgs/SetMode"]
    from ws_status_msgs.msg import RobotStatus
    from ws_status_msgs.srv import SetMode

    response = getattr(SetMode, "Response", None) or SetMode._response_class  # ROS 2's name, ROS 1's
    assert response().status.IDLE == 0
    listener = peer("listen.py", "/built/status", "ws_status_msgs/RobotStatus", "mode")  # another process
    talker = make_node("built_talker").new.publish("/built/status", msgType="ws_status_msgs/RobotStatus").create()
    wait_for(lambda: talker.write("/built/status", RobotStatus(mode="docking", battery=0.4)) or
             any("heard 'docking'" in line for line in listener.lines), timeout=30, interval=0.2,
             what="the built type between two processes")
    talker.shutdown()


def test_ros2_builds_a_packages_actions_too(session, make_node, tmp_path, monkeypatch):
    """ROS 2 builds .action files as well (ROS 1's actions are messages genaction writes, not built here)."""
    if session.backend.name != "ROS 2":
        return
    monkeypatch.setattr(sys, "path", list(sys.path))
    monkeypatch.setenv("PYTHONPATH", os.environ.get("PYTHONPATH", ""))
    monkeypatch.setenv("LD_LIBRARY_PATH", os.environ.get("LD_LIBRARY_PATH", ""))
    package = tmp_path / "ws_count_msgs"
    (package / "action").mkdir(parents=True)
    (package / "action" / "Count.action").write_text("int32 target\n---\nint32 reached\n---\nint32 now\n")
    shown: list[tuple[str, float, str, list[float]]] = []

    @contextlib.contextmanager
    def progress(what, total=None, unit=""):  # a view that keeps what it is told
        steps: list[float] = []
        shown.append((what, total, unit, steps))
        yield steps.append

    monkeypatch.setattr(session, "progress", progress)
    assert build_messages(package, tmp_path / "built") == ["ws_count_msgs/Count"]
    # a few seconds of work: its progress, each generator run and each library compiled a step
    assert [(what, total, unit) for what, total, unit, _ in shown] == \
        [("building ws_count_msgs's message types", 13, "steps")]
    assert shown[0][3] == list(range(1, 14)), shown

    def count(goal, action):
        for i in range(1, goal.target + 1):
            action.feedback({"now": i})
            time.sleep(0.02)
        return {"reached": goal.target}

    make_node("built_counter").new.action("/built/count", "ws_count_msgs/Count", count).create()
    seen: list[int] = []
    goal = make_node("built_count_client").create().send_goal("/built/count", {"target": 3},
                                                               feedback=lambda f: seen.append(f.now))
    assert goal.result(timeout=20).reached == 3 and goal.status == "succeeded"
    wait_for(lambda: seen == [1, 2, 3], timeout=5, what="every feedback of the built action")


def test_a_package_that_cannot_be_built_is_one_line(session, tmp_path, monkeypatch):
    monkeypatch.setattr(sys, "path", list(sys.path))
    monkeypatch.setenv("PYTHONPATH", os.environ.get("PYTHONPATH", ""))
    monkeypatch.setenv("LD_LIBRARY_PATH", os.environ.get("LD_LIBRARY_PATH", ""))
    with pytest.raises(MessageTypeError, match=r"has no msg/\*\.msg.* files; give the folder of a message package"):
        build_messages(tmp_path)
    package = write_package(tmp_path / "bad")
    (package / "msg" / "Broken.msg").write_text("flot64 x\n")
    with pytest.raises(MessageTypeError, match=r"cannot build ws_status_msgs/Broken from .*Broken.msg: "):
        build_messages(package, tmp_path / "built")
    if session.backend.name == "ROS 2":  # ROS 1's bare Header is another package's type on ROS 2
        (package / "msg" / "Broken.msg").write_text("Header header\n")
        with pytest.raises(MessageTypeError, match=r"Header is neither a built-in type nor a message of "
                                                   r"ws_status_msgs; ROS 2 names .* \(std_msgs/Header\)"):
            build_messages(package, tmp_path / "built")
