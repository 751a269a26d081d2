"""A basenode whose ``#!`` line names an interpreter of its own (a workspace's venv) runs on that one (issue 24).

ROS 1 here: a venv made from Debian's python sees rospy, as a catkin workspace's venv would. (On ROS 2 from
PyPI a second venv needs wheels of its own; what ipyros does for it, leaving out its own venv's bootstrap, is
checked in tests/unit/processes/test_basenode.py.)
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from support import wait_for

import ipyros

PEERS = Path(__file__).resolve().parents[1] / "both" / "peers"


def test_a_script_for_another_venv_runs_on_that_venv(make_node, tmp_path):
    """The second venv sees this one's packages (ROS, ipyros) through a .pth file, as a workspace venv sees its
    underlay's: what differs is the interpreter, and what this venv's own start-up set for itself."""
    other = tmp_path / "workspace_venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", "--system-site-packages", str(other)], check=True)
    site = next((other / "lib").glob("python3*/site-packages"))
    (site / "underlay.pth").write_text("\n".join([*(p for p in sys.path if p.endswith("site-packages")),
                                                  str(Path(ipyros.__file__).parents[1]), str(PEERS)]) + "\n")
    script = tmp_path / "ws_node.py"
    script.write_text(f"#!{other / 'bin' / 'python'}\n" + (PEERS / "env_node.py").read_text())
    w = make_node("ws_wrap")
    w.baseNode(str(script), namespace="ws_robot", name="env_node")
    w.create()
    wait_for(lambda: any("env_node ready" in line for line in w.base.tail()), what="the basenode")
    tail = w.base.tail()
    assert f"interpreter {other / 'bin' / 'python'}" in tail, tail
    w.shutdown()
