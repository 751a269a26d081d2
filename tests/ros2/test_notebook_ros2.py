"""The paper's two notebooks, unchanged, run top to bottom on ROS 2 in a fresh kernel, with the ROS 1 suite's checks.

The notebooks say nothing about which ROS they run on: the kernel inherits this run's
``IPYROS_ROS=2`` and DDS domain, and ``%demo`` starts the demo robot on ROS 2. The checks
are the ROS 1 suite's own (tests/support/notebooks.py): the circle's radius is v/ω; the
monitor fires after ``speed = 6`` and not before; the base holds the robot to 5 m/s.
"""

from __future__ import annotations

import pytest

from notebooks import NOTEBOOKS, check_kobuki, check_turtle_circle, run_notebook, text_of

CHECKS = {"turtle_circle.ipynb": check_turtle_circle, "kobuki.ipynb": check_kobuki}


@pytest.mark.parametrize("name", sorted(CHECKS))
def test_the_notebook_runs_on_ros2_and_gets_its_results(name, tmp_path, monkeypatch):
    nb = run_notebook(NOTEBOOKS / name, "", tmp_path, monkeypatch)
    CHECKS[name](nb, text_of(nb))
