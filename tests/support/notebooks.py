"""Running the notebooks in notebooks/ in a fresh Jupyter kernel, and the checks of the paper's two.

Each notebook is executed by nbclient in a real ipykernel (this interpreter, so it sees
the venv's ROS) as a person would run it: the demo robot started with ``%demo``, plots
drawn inline (PNG, the Agg renderer). The checks read what the notebook printed: not only
that it ran, but that the turtle's circle has the radius v/ω, that the monitor fired after
``speed = 6`` and not before, that the base held the robot to 5 m/s.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import nbformat
import pytest
from jupyter_client.kernelspec import KernelSpec
from nbclient import NotebookClient

NOTEBOOKS = Path(__file__).resolve().parents[2] / "notebooks"


def run_notebook(path: Path, master_uri: str, tmp_path: Path, monkeypatch) -> nbformat.NotebookNode:
    """Execute ``path`` in a fresh kernel on ``master_uri``; the executed notebook."""
    nb = nbformat.read(path, as_version=4)
    monkeypatch.setenv("IPYTHONDIR", str(tmp_path / "ipython"))
    monkeypatch.setenv("JUPYTER_RUNTIME_DIR", str(tmp_path / "runtime"))
    monkeypatch.setenv("MPLBACKEND", "Agg")  # no display here; %matplotlib inline draws with Agg anyway
    monkeypatch.setenv("IPYROS_HISTORY_DIR", str(tmp_path / "history"))
    client = NotebookClient(nb, timeout=120, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}})
    spec = KernelSpec(argv=[sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
                      display_name="ipyros", language="python", env={"ROS_MASTER_URI": master_uri})
    client.km = client.create_kernel_manager()
    client.km._kernel_spec = spec
    client.execute()
    return nb


def text_of(nb: nbformat.NotebookNode) -> str:
    """Everything the code cells printed or displayed as text, colours removed."""
    parts = []
    for cell in nb.cells:
        for out in cell.get("outputs", []) if cell.cell_type == "code" else []:
            parts.append(out.get("text", "") or "\n".join(str(v) for k, v in out.get("data", {}).items()
                                                           if k.startswith("text/")))
    return re.sub(r"\x1b\[[0-9;]*m", "", "\n".join(parts))  # rich colours text/plain in a kernel


def cell_with(nb: nbformat.NotebookNode, source: str) -> nbformat.NotebookNode:
    """The first code cell whose source contains ``source``."""
    return next(c for c in nb.cells if c.cell_type == "code" and source in c.source)


def text_of_cell(cell: nbformat.NotebookNode) -> str:
    """What one cell printed or displayed as text."""
    return text_of(nbformat.v4.new_notebook(cells=[cell]))


def html_of(cell: nbformat.NotebookNode) -> str:
    """The HTML one cell displayed."""
    return "\n".join(out.get("data", {}).get("text/html", "") for out in cell.get("outputs", []))


def images(nb: nbformat.NotebookNode) -> int:
    """How many PNG images the notebook shows (its plots)."""
    return sum("image/png" in out.get("data", {}) for cell in nb.cells if cell.cell_type == "code"
               for out in cell.get("outputs", []))


def number(pattern: str, text: str) -> tuple[float, ...]:
    """The numbers ``pattern``'s groups catch in ``text`` (which must match)."""
    match = re.search(pattern, text)
    assert match, f"no {pattern!r} in the notebook's output:\n{text}"
    return tuple(float(g) for g in match.groups())


# -- the checks, one function per notebook ---------------------------------------------------

def check_turtle_circle(nb: nbformat.NotebookNode, text: str) -> None:
    assert "demo robot turtle (running)" in text
    for circle, v_over_w in (("1", 2.0 / 1.8), ("2", 2.0 / 3.6)):
        fitted, printed = number(rf"circle {circle}: radius ([\d.]+) m fitted, v/ω = ([\d.]+) m", text)
        assert printed == pytest.approx(v_over_w, abs=0.001)
        assert fitted == pytest.approx(v_over_w, rel=0.05), f"circle {circle}: radius {fitted} m, not v/ω"
    assert images(nb) == 1, "the trajectory plot is missing"
    assert "demo robot turtle stopped" in text


def check_kobuki(nb: nbformat.NotebookNode, text: str) -> None:
    assert "demo robot kobuki (running)" in text
    assert "rosNode /experimental_move_base (running) wrapping ipyros_demo/move_base" in text
    (relayed,) = number(r"the base is told ([\d.]+) m/s: move_base's own speed, relayed", text)
    assert relayed == 1.0, text  # relayVelocity passes move_base's ~speed on
    assert "before speed = 6: speed_exceeded was [False]" in text, "the monitor fired before speed = 6"
    # after the first 6 m/s command, not before it (both times are when this kernel saw the messages,
    # on two threads: a few milliseconds either way are noise, not an early alarm)
    (delay,) = number(r"after speed = 6: speed_exceeded went True (-?[\d.]+) s after the first 6 m/s command", text)
    assert -0.05 <= delay < 2.0
    top_commanded, top_driven = number(r"top speed: commanded ([\d.]+) m/s, driven ([\d.]+) m/s", text)
    assert top_commanded == 6.0
    assert top_driven == pytest.approx(5.0, abs=0.25), "the base did not hold the robot to its 5 m/s limit"
    assert "speed 6.00 m/s exceeds max_speed 5.00 m/s" in text  # the monitor's own log line
    # the rule as a guard: the output clamped to 5 m/s, held at rest while e-stopped, released
    assert "with the guard, speed = 6.0: the base is told 5.0 m/s" in text
    assert "e-stopped: the base is told 0.0 m/s while the planner still asks for 6.0" in text
    assert "released: the base is told 5.0 m/s again" in text
    assert re.search(r"mobile_base/commands/velocity.*passing", text), "%status shows no guard"
    # a rule over what the robot senses: nothing but backing off while the bumper is pressed against the wall
    assert "against the wall: the planner asks for 6.0 m/s, the base is told 0.0 m/s" in text
    assert "when /mobile_base/events/bumper.data: only linear.x <= 0 (in force)" in text, "%status shows no rule"
    assert "rule 1: only linear.x <= 0" in text, "the guard did not say that its rule acted"
    # the session drawn as the paper draws wrapping: the planner inside its wrapping node, the guard on its output
    svg = "\n".join(out.get("data", {}).get("image/svg+xml", "") for out in cell_with(nb, "%graph").outputs)
    said = re.findall(r">([^<>]+)</text>", svg)
    assert "/experimental_move_base wraps ipyros_demo/move_base" in said and "(basenode)" in said, said
    assert {"/cmd_vel: replaced by controlVelocity", "/move_base_simple/goal: relayed"} <= set(said), said
    assert any(re.fullmatch(r"guard: passing, \d+ clamped", text) for text in said), said
    recorded, top = number(r"the live plot recorded (\d+) commands, up to ([\d.]+) m/s", text)
    assert recorded >= 20 and top == 6.0, "the live plot did not follow the commands"
    assert images(nb) == 2, "the live plot or the speed plot is missing"
    assert "demo robot kobuki stopped" in text


def check_tour(nb: nbformat.NotebookNode, text: str) -> None:
    assert "rosNode /turtle (running) wrapping ipyros_demo/turtle_sim" in text
    assert "rosNode /turtle_control_node (running)" in text
    assert "the turtle is at x=" in text and "x=0.00, y=0.00" not in text
    assert "/turtle1/pose" in text and "geometry_msgs/Pose" in text
    assert images(nb) == 1, "the live plot of the turtle's path is missing"
    assert "status of /turtle_control_node" in text
    # In Jupyter a status is an HTML table, and what a handler prints stays below the cell that made its node.
    assert '<caption style="text-align:left">status of /turtle_control_node</caption>' in html_of(cell_with(nb, "%status nd"))
    created, swapped = cell_with(nb, 'nd = rosNode("turtle_control_node")'), cell_with(nb, "if len(poses) % 20 == 0")
    assert re.search(r"^x=-?\d", text_of_cell(created), re.M), "the handler's prints are not below the creating cell"
    assert "x=" not in text_of_cell(swapped), "the handler's prints landed in the cell that ran when they came"
    assert "versions of the handler of turtle_control_node /turtle1/pose" in text
    assert "live handler: showPose version 1" in text
    assert "ipyros: saved /turtle_control_node to" in text and "with restoring():" in text
    assert "ipyros: loaded /turtle_control_node (running)" in text
    restored, versions = number(r"poses since the restore: (\d+) \| handler versions: (\d+)", text)
    assert restored > 5 and versions == 2, "the restored node does not get poses, or lost a handler version"
