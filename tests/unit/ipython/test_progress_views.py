"""Progress is drawn in a terminal (a rich bar, gone when done) and nowhere when the output is not a terminal."""

from __future__ import annotations

import io
import sys
import time
from types import SimpleNamespace

from ipyros.ipython import progress
from ipyros.ipython.progress import view


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_a_terminal_gets_a_bar_that_says_what_and_is_gone_when_done(monkeypatch):
    out = Terminal()
    monkeypatch.setattr(sys, "stdout", out)
    monkeypatch.setattr(progress, "DELAY", 0.0)
    with view(SimpleNamespace(kernel=None))("converting run.bag", 4096, "messages") as step:
        step(2048)
        deadline = time.monotonic() + 10
        while "2,048/4,096" not in out.getvalue() and time.monotonic() < deadline:  # drawn by rich's own thread
            time.sleep(0.01)
    drawn = out.getvalue()
    assert "converting run.bag" in drawn and "2,048/4,096 messages" in drawn
    assert drawn.endswith("\x1b[1A\x1b[2K")  # the line erased once the work is done


def test_output_that_is_not_a_terminal_gets_nothing(monkeypatch):
    out = io.StringIO()
    monkeypatch.setattr(sys, "stdout", out)
    with view(SimpleNamespace(kernel=None))("converting run.bag", 4096, "messages") as step:
        step(2048)
    assert out.getvalue() == ""


def test_work_of_a_moment_shows_nothing_even_in_a_terminal(monkeypatch):
    out = Terminal()
    monkeypatch.setattr(sys, "stdout", out)
    with view(SimpleNamespace(kernel=None))("waiting for /base", None) as step:
        step(1)
    assert out.getvalue() == ""
