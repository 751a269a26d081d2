"""Every notebook in notebooks/ runs top to bottom and gets the results it should: here in a fresh Jupyter kernel,
or, for those JupyterLab runs in test_browser.py, there (the same checks, on the notebook as the page saves it).

The kernel runs against the test master. A notebook without checks here fails, so a new
notebook cannot slip in untested (the checks are in support/notebooks.py, which the ROS 2
suite and the browser test run them with too).
"""

from __future__ import annotations

from typing import Callable

import nbformat
import pytest

from notebooks import NOTEBOOKS, check_kobuki, check_tour, check_turtle_circle, run_notebook, text_of


CHECKS: dict[str, Callable[[nbformat.NotebookNode, str], None]] = {
    "tour.ipynb": check_tour,
    "turtle_circle.ipynb": check_turtle_circle,
    "kobuki.ipynb": check_kobuki,
}


def test_every_notebook_has_checks():
    found = sorted(p.name for p in NOTEBOOKS.glob("*.ipynb"))
    assert found == sorted(CHECKS), "a notebook in notebooks/ without checks here, or checks of a notebook gone"


#: Run in JupyterLab by test_browser.py, which applies the same checks to the notebook as the page saves it: a
#: second run here, in a kernel of nbclient's, would check nothing more (ROS 2 runs the paper's two in a kernel).
IN_THE_BROWSER = {"tour.ipynb", "kobuki.ipynb"}


@pytest.mark.parametrize("name", sorted(set(CHECKS) - IN_THE_BROWSER))
def test_the_notebook_runs_and_gets_its_results(name, ros_master, tmp_path, monkeypatch):
    nb = run_notebook(NOTEBOOKS / name, ros_master, tmp_path, monkeypatch)
    CHECKS[name](nb, text_of(nb))
