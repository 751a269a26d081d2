"""Peer, run as a basenode: prints ``interpreter <sys.executable>``, ``mode <$ROBOT_MODE>`` and whether this venv's
bootstrap guard came in (``guard <value or ->``), then spins as node ``env_node``."""
import os
import sys

from anyros import DemoNode

print("interpreter", sys.executable, flush=True)
print("mode", os.environ.get("ROBOT_MODE", "-"), flush=True)
print("guard", os.environ.get("_ROS_WHEELS_BOOTSTRAP_COMPLETE", "-"), flush=True)
node = DemoNode("env_node")
print("env_node ready", flush=True)
node.run(10.0, lambda: None)
