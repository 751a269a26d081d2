"""Every notebook in notebooks/ runs top to bottom in a fresh Jupyter kernel, and gets the results it should.

The kernel runs against the test master. A notebook without checks here fails, so a new
notebook cannot slip in untested (the helpers and the paper notebooks' checks are in
support/notebooks.py, which the ROS 2 suite runs them with too).
"""

from __future__ import annotations

import re
from typing import Callable

import nbformat
import pytest

from notebooks import (
    NOTEBOOKS,
    cell_with,
    check_kobuki,
    check_turtle_circle,
    html_of,
    images,
    number,
    run_notebook,
    text_of,
    text_of_cell,
)


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


CHECKS: dict[str, Callable[[nbformat.NotebookNode, str], None]] = {
    "tour.ipynb": check_tour,
    "turtle_circle.ipynb": check_turtle_circle,
    "kobuki.ipynb": check_kobuki,
}


def test_every_notebook_has_checks():
    found = sorted(p.name for p in NOTEBOOKS.glob("*.ipynb"))
    assert found == sorted(CHECKS), "a notebook in notebooks/ without checks here, or checks of a notebook gone"


@pytest.mark.parametrize("name", sorted(CHECKS))
def test_the_notebook_runs_and_gets_its_results(name, ros_master, tmp_path, monkeypatch):
    nb = run_notebook(NOTEBOOKS / name, ros_master, tmp_path, monkeypatch)
    CHECKS[name](nb, text_of(nb))
