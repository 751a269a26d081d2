"""The tour notebook runs top to bottom in a real Jupyter kernel, against the test master."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import nbformat
from nbclient import NotebookClient

NOTEBOOK = Path(__file__).resolve().parents[1] / "notebooks" / "tour.ipynb"


def test_the_tour_notebook_runs(ros_master, tmp_path, monkeypatch):
    nb = nbformat.read(NOTEBOOK, as_version=4)
    monkeypatch.setenv("IPYTHONDIR", str(tmp_path / "ipython"))
    monkeypatch.setenv("JUPYTER_RUNTIME_DIR", str(tmp_path / "runtime"))
    # The kernel is this interpreter, so it sees the venv and Debian's rospy.
    client = NotebookClient(nb, timeout=120, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}})
    client.kernel_manager_class.kernel_cmd = None  # use the kernelspec below
    from jupyter_client.kernelspec import KernelSpec

    spec = KernelSpec(argv=[sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
                      display_name="ipyros", language="python", env={"ROS_MASTER_URI": ros_master})
    client.km = client.create_kernel_manager()
    client.km._kernel_spec = spec
    client.execute()
    outputs = {i: cell.get("outputs", []) for i, cell in enumerate(nb.cells) if cell.cell_type == "code"}
    text = "\n".join(out.get("text", "") or "\n".join(str(v) for v in out.get("data", {}).values())
                     for cell_outputs in outputs.values() for out in cell_outputs)
    text = re.sub(r"\x1b\[[0-9;]*m", "", text)  # rich colours text/plain in a kernel; Jupyter renders them
    assert "rosNode /turtle (running) wrapping ipyros_demo/turtle_sim" in text
    assert "rosNode /turtle_control_node (running)" in text
    assert "the turtle is at x=" in text and "x=0.00, y=0.00" not in text
    assert "/turtle1/pose" in text and "geometry_msgs/Pose" in text
    assert "status of /turtle_control_node" in text
