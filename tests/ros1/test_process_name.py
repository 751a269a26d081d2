"""ROS 1: the session's one rospy node carries the user's first node's name, even when a helper ran first."""

from __future__ import annotations

import os
import subprocess
import sys

from helpers import one_call
from ros1_fixtures import master_state

SESSION = """
import sys
from ipyros import rosNode
from ipyros.tools.probe import Echo
from std_msgs.msg import String

with Echo("/named/in", "std_msgs/String") as echo:  # %echo before any create(): rospy starts as the helper
    assert echo.get(20) is not None, "the helper hears the talker"
    print("TOOL", echo.node.name, flush=True)
    nd = rosNode("first_user_node")
    nd.new.publish("/named/out", msgType=String)
    nd.create()
    while echo.get(0) is not None:
        pass
    assert echo.get(20) is not None, "the helper still hears after the node took its name"
    print("READY", flush=True)
    sys.stdin.readline()
"""


def test_a_helper_started_first_leaves_the_name_to_the_users_node(ros_master, peer):
    talker = peer("talk.py", "/named/in", "std_msgs/String", 20, "data='hi'")
    talker.wait_line("ready")
    proc = subprocess.Popen([sys.executable, "-c", SESSION], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env={**os.environ, "ROS_MASTER_URI": ros_master})
    try:
        tool = proc.stdout.readline().split()
        assert tool[:1] == ["TOOL"], proc.stderr.read() if proc.poll() is not None else tool
        assert proc.stdout.readline().strip() == "READY", proc.stderr.read() if proc.poll() is not None else ""
        master = one_call(ros_master)
        code, _, api = master.lookupNode("/pytest", "/first_user_node")
        assert code == 1, "the user's node is on the master under its own name"
        assert one_call(api).getName("/pytest")[2] == "/first_user_node"
        assert master.lookupNode("/pytest", "/" + tool[1])[0] != 1, "the helper's name is gone from the master"
        state = master_state(ros_master)
        assert state["pub"]["/named/out"] == ["/first_user_node"]
        assert "/first_user_node" in state["sub"]["/named/in"], "the helper's subscription moved with the name"
        assert {"/first_user_node/get_loggers", "/first_user_node/set_logger_level"} <= set(state["srv"])
        assert not any(tool[1] in name for name in state["srv"]), "rospy's own services were renamed too"
        proc.stdin.close()
        assert proc.wait(30) == 0, proc.stderr.read()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
