"""The README's promise, kept in a real terminal: its first command, then its five lines, and the turtle moves.

``bash run.sh`` runs under tmux exactly as the README says to type it, with a home of
its own and ``ROS_MASTER_URI`` on a free port where nothing answers: so ipyros starts
its embedded master there, isolated from the test master and from anyone's roscore.
The test waits for the demo turtle and the hint, types the README's five lines (read
from the README itself, so the two cannot drift apart), watches the pose change, and
exits: the master, rosout and the turtle must all be gone.
"""

from __future__ import annotations

import os
import re

import pytest
from helpers import pid_alive
from readme import ROOT, readme_lines, watch_the_turtle_go_round
from ros1_fixtures import free_port, wait_for
from terminal import Terminal, descendants, prompt, run

from ipyros.tools.robot import TURTLE_CIRCLE


def test_the_readme_shows_the_lines_the_demo_suggests():
    assert readme_lines() == list(TURTLE_CIRCLE) and len(TURTLE_CIRCLE) == 5


@pytest.fixture
def readme_terminal(tmp_path):
    """``bash run.sh`` in tmux, 160x50, on an embedded master of its own; closed (and checked gone) after."""
    home = tmp_path / "home"
    home.mkdir()
    env = {**os.environ, "HOME": str(home), "IPYTHONDIR": str(home / ".ipython"),
           "ROS_MASTER_URI": f"http://localhost:{free_port()}", "ROS_HOME": str(tmp_path / "ros"),
           "ROS_LOG_DIR": str(tmp_path / "ros" / "log"), "IPYROS_HISTORY_DIR": str(tmp_path / "history")}
    for name in ("PYTHONSTARTUP", "COLUMNS", "LINES", "VIRTUAL_ENV"):
        env.pop(name, None)
    with Terminal("ipyros_readme", ["bash", str(ROOT / "run.sh")], env, width=160, height=50) as term:
        yield term


def test_the_readme_first_command_and_five_lines_move_the_turtle(readme_terminal):
    term = readme_terminal
    # run.sh may have a package to install first (a fresh clone): generous time for the first prompt.
    term.wait_for(lambda rows: prompt(rows) == (1, "") and rows, timeout=120, what="the first prompt")
    screen = "\n".join(term.screen(history=True))
    assert "starting one there" in screen  # nothing answered: ipyros's embedded master
    assert "demo robot turtle (running)" in screen and "Drive it in a circle" in screen
    assert all(line in screen for line in TURTLE_CIRCLE)  # the hint is the README's five lines

    for line in readme_lines():
        run(term, line)
    assert "rosNode /turtle_control_node (running)" in "\n".join(term.screen(history=True))

    # "poses[-1].position, typed again and again": it changes, away from the origin, on the circle.
    watch_the_turtle_go_round(term)

    # The node's status, history and handler versions print as tables, not as dataclass text.
    for call, title in (("nd.status()", "status of /turtle_control_node"),
                        ("nd.history()", "history of /turtle_control_node"),
                        ('nd.versions("/turtle1/pose")', "versions of the handler of turtle_control_node /turtle1/pose")):
        term.press("C-l")
        run(term, call)
        screen = "\n".join(term.screen())
        assert title in screen and "━━━" in screen, screen
        assert not re.search(r"(NodeStatus|History|Versions)\(", screen), screen

    # Wrapping move_base, whose reuse relay reads /turtle1/pose as bytes beside nd's typed handler:
    # both go on getting theirs, and no traceback floods the prompt.
    term.press("C-l")
    run(term, "%wrap ipyros_demo move_base --as mb", timeout=60)
    run(term, "before = len(poses)")

    def both_served(rows):
        term.press("C-l")
        run(term, 'print("SERVED", len(poses) - before > 10, min(r.calls for r in mb.status().rows '
                  'if r.kind == "relay" and r.name.endswith("turtle1/pose")) > 10)')
        return any(row.strip() == "SERVED True True" for row in term.screen())

    term.wait_for(both_served, timeout=30, what="poses for nd's handler and for move_base's relay", interval=0.5)
    screen = "\n".join(term.screen(history=True))
    assert "Traceback" not in screen and "_buff" not in screen, screen

    # %graph: the wrapped move_base drawn as a tree that fits the terminal, at 80 columns and at 200.
    for width in (80, 200):
        term.resize(width)
        term.press("C-l")
        run(term, "%graph --types")
        rows = term.screen(joined=True)
        drawn = "\n".join(rows)
        assert "/mb" in drawn and "/move_base" in drawn and "/turtle1/pose" in drawn, drawn
        assert max(map(len, rows)) <= width, f"a line over {width} columns:\n{drawn}"
    term.resize(160)

    # TAB after %pub TOPIC: the type the live topic carries comes first.
    term.type("%pub /turtle1/cmd_vel ")
    term.press("Tab")

    def menu_first(rows):
        at = next((i for i, row in enumerate(rows) if row.startswith("In [") and "%pub /turtle1/cmd_vel" in row), None)
        return at is not None and at + 1 < len(rows) and rows[at + 1].split()[:1] == ["geometry_msgs/Twist"]

    term.wait_for(menu_first, timeout=20, what="the menu, the live topic's type first")
    term.press("Tab")  # selects the first: the type the topic carries
    term.wait_for(lambda rows: any(row.rstrip().endswith("%pub /turtle1/cmd_vel geometry_msgs/Twist")
                                   for row in rows), timeout=20, what="the live type inserted")
    # Ctrl-C closes the menu, then clears the line.
    term.wait_for(lambda rows: (p := prompt(rows)) and p[1] == "" or term.press("C-c"), timeout=20,
                  what="Ctrl-C to clear the line", interval=0.5)

    # exit: the session stops the turtle, rosout and the master it started.
    family = descendants(term.pid)
    assert len(family) >= 3, f"expected the master, rosout and turtle_sim below IPython, found {family}"
    term.line("exit")
    term.wait_for(lambda rows: not term.alive() or None, timeout=30, what="IPython to exit")
    wait_for(lambda: not [pid for pid in {term.pid, *family} if pid_alive(pid)], timeout=15,
             what="IPython's processes to end")
