"""A workspace's own message package made importable at the prompt with one call (issue 24): ROS 1 builds it with
genpy, here and for the processes started after; ROS 2 says in one line how such a package is built."""

from __future__ import annotations

import os
import sys

import pytest
from support import wait_for

from ipyros import build_messages
from ipyros.core.errors import MessageTypeError


def write_package(root):
    package = root / "ws_status_msgs"
    (package / "msg").mkdir(parents=True)
    (package / "srv").mkdir()
    (package / "package.xml").write_text("<package format='2'><name>ws_status_msgs</name></package>\n")
    (package / "msg" / "RobotStatus.msg").write_text("# what the robot says of itself\nHeader header\nstring mode\n"
                                                     "float64 battery\ngeometry_msgs/Point where\nuint8 IDLE=0\n")
    (package / "srv" / "SetMode.srv").write_text("string mode\n---\nbool ok\nRobotStatus status\n")
    return package


def test_a_message_package_is_built_and_used_by_the_session_and_its_peers(session, make_node, peer, tmp_path,
                                                                          monkeypatch):
    package = write_package(tmp_path)
    monkeypatch.setattr(sys, "path", list(sys.path))  # what the build adds is taken back after the test
    monkeypatch.setenv("PYTHONPATH", os.environ.get("PYTHONPATH", ""))
    if session.backend.name != "ROS 1":  # ROS 2
        with pytest.raises(MessageTypeError, match="colcon build it"):
            build_messages(package, tmp_path / "built")
        return
    assert build_messages(package, tmp_path / "built") == ["ws_status_msgs/RobotStatus", "ws_status_msgs/SetMode"]
    from ws_status_msgs.msg import RobotStatus
    from ws_status_msgs.srv import SetMode

    assert SetMode._response_class().status.IDLE == 0
    listener = peer("listen.py", "/built/status", "ws_status_msgs/RobotStatus", "mode")  # another process
    talker = make_node("built_talker").new.publish("/built/status", msgType="ws_status_msgs/RobotStatus").create()
    wait_for(lambda: talker.write("/built/status", RobotStatus(mode="docking", battery=0.4)) or
             any("heard 'docking'" in line for line in listener.lines), timeout=30, interval=0.2,
             what="the built type between two processes")
    talker.shutdown()


def test_a_package_that_cannot_be_built_is_one_line(session, tmp_path, monkeypatch):
    if session.backend.name != "ROS 1":
        return  # ROS 2: refused as above
    monkeypatch.setattr(sys, "path", list(sys.path))
    monkeypatch.setenv("PYTHONPATH", os.environ.get("PYTHONPATH", ""))
    with pytest.raises(MessageTypeError, match=r"has no msg/\*\.msg or srv/\*\.srv files; give the folder of a message package"):
        build_messages(tmp_path)
    package = write_package(tmp_path / "bad")
    (package / "msg" / "Broken.msg").write_text("flot64 x\n")
    with pytest.raises(MessageTypeError, match=r"cannot build ws_status_msgs/Broken from .*Broken.msg: "):
        build_messages(package, tmp_path / "built")
