"""The notebook face checked in a real browser: JupyterLab (from PyPI) in Debian's headless Chromium, driven by
playwright, its kernels on the test master.

What a person sees, read from the page: the tour runs top to bottom from the Run menu with no error output;
``%topics`` is an HTML table, ``%graph`` an SVG of the wrapping and ``%plot`` a figure redrawn while the tour goes
on; a ``%pub --widget`` slider dragged with the mouse publishes the value it shows, as a plain subscriber receives it. Screenshots land in the
test's temporary folder (``pytest --basetemp DIR`` keeps them to look at). Through kernel messages alone the same
is tested in test_kernel.py and test_notebook.py; here it is the browser's rendering that must hold.
"""

from __future__ import annotations

import re
import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import nbformat
import pytest
from browser import TIMEOUT, Browser, Lab, NotebookPage
from support import wait_for

from notebooks import NOTEBOOKS, check_kobuki, check_tour, text_of

pytestmark = pytest.mark.timeout(4 * TIMEOUT)  # JupyterLab and Chromium on a loaded machine of 2 cores

@pytest.fixture(scope="module")
def lab(ros_master, tmp_path_factory):
    """A JupyterLab server of this module's own, serving a folder with a copy of the tour."""
    root = tmp_path_factory.mktemp("lab")
    shutil.copy(NOTEBOOKS / "tour.ipynb", root)
    running = Lab(root, tmp_path_factory.mktemp("lab_home"), ros_master)
    try:
        yield running
    finally:
        running.stop()


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    running = Browser(tmp_path_factory.mktemp("chromium_home"))
    try:
        yield running
    finally:
        running.close()


@dataclass
class Tour:
    """The tour as it ran in the browser: its page, the error outputs once every cell had run, each picture the
    live plot showed meanwhile (its ``src``), and the folder of the screenshots."""

    notebook: NotebookPage
    errors: list[str]
    figures: list[str] = field(default_factory=list)
    shots: Path = Path()
    saved: Any = None  # the notebook as the page saved it once every cell had run


def _pictures(cell: Any) -> list[str]:
    """The ``src`` of every image the cell's outputs show now (none yet: an empty list, at once)."""
    return cell.locator(".jp-OutputArea-output img").evaluate_all("images => images.map(image => image.src)")


@pytest.fixture(scope="module")
def tour(lab, browser, tmp_path_factory):
    """The tour run top to bottom from the Run menu; the live plot watched while the other cells run."""
    shots = tmp_path_factory.mktemp("screenshots")
    notebook = NotebookPage(lab, browser, "tour.ipynb", shots)
    try:
        notebook.run_all()
        plot = notebook.cell("%plot /turtle1/pose")
        figures: list[str] = []
        deadline = time.monotonic() + TIMEOUT
        while not notebook.ran() and not notebook.errors():  # Run All stops at an error: the rest never runs
            assert time.monotonic() < deadline, f"the tour did not finish within {TIMEOUT} s"
            figures += [src for src in _pictures(plot) if src not in figures]
            time.sleep(0.2)
        yield Tour(notebook, notebook.errors(), figures, shots, notebook.saved() if notebook.ran() else None)
    finally:
        notebook.close()


#: Colours read from screenshots: text as JupyterLab draws it, and matplotlib's first line colour ("C0").
TEXT, LINE = (0, 0, 0), (31, 119, 180)


def _pixels_like(png: Path, colour: tuple[int, int, int], within: int = 60) -> int:
    """How many pixels of a screenshot are close to ``colour`` (each channel within ``within``)."""
    from PIL import Image

    with Image.open(png) as picture:
        colours = picture.convert("RGB").getcolors(maxcolors=picture.width * picture.height)
    return sum(count for count, rgb in colours if all(abs(a - b) <= within for a, b in zip(rgb, colour)))


def test_the_tour_runs_top_to_bottom_in_the_browser_with_no_error_output(tour):
    assert tour.errors == [], "the tour shows error output in the browser:\n" + "\n---\n".join(tour.errors)
    last = tour.notebook.cell("%load_nodes $saved")
    last.scroll_into_view_if_needed()  # JupyterLab draws the cells in view only
    said = wait_for(lambda: [t for t in last.locator(".jp-OutputArea-output").all_inner_texts() if t.strip()],
                    timeout=10, what="the last cell's output drawn")
    assert any("poses since the restore:" in text for text in said), said  # the last cells ran, and saw poses


def test_the_tour_gets_its_results_in_the_browser(tour):
    """What the tour shows, as the page saved it, holds what a kernel's run must (instead of a second run)."""
    assert tour.saved is not None, "the tour did not run to its end"
    check_tour(tour.saved, text_of(tour.saved))


def test_topics_is_an_html_table_in_the_browser(tour):
    table = tour.notebook.cell("%topics /turtle1").locator(".jp-OutputArea-output table")
    assert table.count() == 1 and table.is_visible()
    # scrolled into view, the rows are drawn a moment later (until then their text reads as empty: once in CI)
    wait_for(lambda: any("/turtle1" in row for row in table.locator("tr").all_inner_texts()), timeout=10,
             what="the table's rows drawn")
    rows = table.locator("tr").all_inner_texts()
    assert any("/turtle1/pose" in row and "geometry_msgs/Pose" in row for row in rows), rows
    assert any("/turtle1/cmd_vel" in row and "geometry_msgs/Twist" in row for row in rows), rows
    shot = tour.shots / "topics.png"
    table.screenshot(path=str(shot))
    assert _pixels_like(shot, TEXT) > 500, f"no text in the table's screenshot: {shot}"


def test_graph_is_an_svg_of_the_wrapping_in_the_browser(tour):
    """%graph: one SVG below the cell (JupyterLab draws it as an image), the wrapping node's frame around the turtle
    it launched, the topics named in its text."""
    svg = _drawn(tour.notebook.cell("%graph /turtle1*"), tour.shots / "graph.png")
    assert "wraps ipyros_demo/turtle_sim" in svg and "/turtle1/pose" in svg and "(basenode)" in svg, svg[:400]


def _drawn(cell: Any, shot: Path) -> str:
    """The SVG text of the one picture below ``cell``, once the browser has drawn it with text in it (``shot``)."""
    from urllib.parse import unquote

    cell.scroll_into_view_if_needed()  # JupyterLab draws the cells in view only
    picture = cell.locator(".jp-OutputArea-output img")
    wait_for(lambda: picture.count() == 1, timeout=10, what="the picture drawn")
    source = picture.get_attribute("src")
    assert source.startswith("data:image/svg+xml,"), source[:80]
    width = picture.evaluate("image => image.naturalWidth")
    assert width > 200, "the browser did not draw the picture"
    picture.screenshot(path=str(shot))
    assert _pixels_like(shot, TEXT) > 200, f"no text in the picture's screenshot: {shot}"
    return unquote(source.split(",", 1)[1])


#: How the guard of the kobuki's base begins each line it says (on stderr, below the cell that runs), and the rule
#: whose acting it says there.
GUARD_SAYS, BUMPER_RULE = "ipyros: guard /mobile_base/commands/velocity: ", "rule 1: only linear.x <= 0"


def test_the_wrapped_kobuki_is_drawn_in_the_browser(lab, browser, tmp_path):
    """The paper's second session run from the Run menu: its %graph draws move_base inside its wrapping node, the
    handler that replaced its cmd_vel, and the guard on the output to the base with what it did."""
    shutil.copy(NOTEBOOKS / "kobuki.ipynb", lab.root)
    notebook = NotebookPage(lab, browser, "kobuki.ipynb", tmp_path)
    try:
        notebook.run_all()

        def errors() -> list[str]:  # what the guard says as its bumper rule acts is no error
            return [text for text in notebook.errors() if not all(
                line.startswith(GUARD_SAYS) and BUMPER_RULE in line for line in text.strip().splitlines())]

        wait_for(lambda: notebook.ran() or errors(), timeout=TIMEOUT, interval=0.2, what="the notebook to run to its end")
        assert errors() == [], "\n---\n".join(errors())
        svg = _drawn(notebook.cell("%graph --node /experimental_move_base"), tmp_path / "kobuki-graph.png")
        assert "/experimental_move_base wraps ipyros_demo/move_base" in svg and "(basenode)" in svg, svg[:400]
        assert "/cmd_vel: replaced by controlVelocity" in svg and re.search(r"guard: passing, \d+ clamped", svg)
        saved = notebook.saved()  # the paper's numbers, as the page shows them (instead of a second run)
        check_kobuki(saved, text_of(saved))
    finally:
        notebook.close()


def test_plot_is_a_live_figure_in_the_browser(tour):
    assert len(tour.figures) >= 3, f"the plot was not redrawn while the tour ran: {len(tour.figures)} pictures shown"
    outputs = tour.notebook.cell("%plot /turtle1/pose").locator(".jp-Cell-outputArea")
    figure = outputs.locator("img")
    assert figure.count() == 1, "one figure below the cell, redrawn in place (not one more each time)"
    width, height = figure.evaluate("image => [image.naturalWidth, image.naturalHeight]")
    assert width > 200 and height > 150, "the browser did not draw the figure"
    shot = tour.shots / "plot.png"
    outputs.screenshot(path=str(shot))  # the area, not the picture: a live one is replaced as it is taken
    assert _pixels_like(shot, LINE, within=30) > 100, f"no line drawn in the figure's screenshot: {shot}"


GUARDED = """\
from geometry_msgs.msg import Twist
base = rosNode("browser_base")
base.new.publish("/browser/guarded", msgType=Twist)
base.guard("/browser/guarded", limits={"linear.x": (-0.5, 0.5)})
base.create()"""


def _drag(page: Any, slider: Any, dx: float) -> float:
    """Drag a slider's handle ``dx`` pixels with the mouse, as a person does; the value it then shows."""
    handle = slider.locator(".noUi-handle").bounding_box()
    x, y = handle["x"] + handle["width"] / 2, handle["y"] + handle["height"] / 2
    page.mouse.move(x, y)
    page.mouse.down()
    page.mouse.move(x + dx, y, steps=5)
    page.mouse.up()
    return float(slider.locator(".widget-readout").inner_text())


def test_a_pub_widget_slider_moved_in_the_browser_publishes_what_it_shows(lab, browser, peer, tmp_path):
    """An unguarded topic's slider, dragged then stepped; a guarded topic's slider dragged far past the guard's
    limit: it stops there, and the robot gets the value it shows, not more."""
    nbformat.write(nbformat.v4.new_notebook(
        cells=[nbformat.v4.new_code_cell("%load_ext ipyros"),
               nbformat.v4.new_code_cell("%pub --widget /browser/cmd geometry_msgs/Twist"),
               nbformat.v4.new_code_cell(GUARDED),
               nbformat.v4.new_code_cell("%pub --widget /browser/guarded geometry_msgs/Twist")],
        metadata={"kernelspec": {"name": "python3", "display_name": "Python 3", "language": "python"}}),
        lab.root / "widget.ipynb")
    robots = {topic: peer("listen_twist.py", topic, f"--name=browser_robot{n}")  # plain rospy subscribers
              for n, topic in enumerate(("/browser/cmd", "/browser/guarded"))}
    for robot in robots.values():
        robot.wait_line("ready")

    def received(topic: str) -> float | None:
        """The linear.x of the last message the subscriber of ``topic`` printed."""
        last = next((line for line in reversed(robots[topic].lines) if line.startswith("twist ")), None)
        return float(last.split()[1]) if last else None

    def arrives(topic: str, value: float) -> None:
        wait_for(lambda: received(topic) == pytest.approx(value, abs=5e-4), timeout=30, interval=0.1,
                 what=f"the subscriber of {topic} to receive linear.x = {value}, shown on the slider "
                      f"(last: {received(topic)})")

    notebook = NotebookPage(lab, browser, "widget.ipynb", tmp_path)
    try:
        notebook.run_all()
        slider = notebook.cell("%pub --widget /browser/cmd").locator(".widget-slider").filter(has_text="linear.x")
        slider.wait_for(timeout=TIMEOUT * 1000)
        readout = slider.locator(".widget-readout")
        assert float(readout.inner_text()) == 0.0 and received("/browser/cmd") is None, "sent before it moved"
        shown = _drag(notebook.page, slider, 25)  # to the right: positive, a few m/s
        assert shown > 0, "the drag did not move the slider"
        arrives("/browser/cmd", shown)
        slider.locator(".noUi-handle").press("ArrowLeft")  # the keyboard moves it one step
        wait_for(lambda: float(readout.inner_text()) < shown, timeout=10, what="the slider to move a step left")
        arrives("/browser/cmd", float(readout.inner_text()))
        assert notebook.page.get_by_text("/browser/cmd: ").inner_text().endswith(" sent")

        guarded = notebook.cell("%pub --widget /browser/guarded")
        assert "through the guard of browser_base" in guarded.inner_text()
        slider = guarded.locator(".widget-slider").filter(has_text="linear.x")
        assert _drag(notebook.page, slider, 300) == 0.5, "the guarded slider goes past the guard's limit"
        arrives("/browser/guarded", 0.5)
        assert notebook.errors() == []
    finally:
        notebook.close()
