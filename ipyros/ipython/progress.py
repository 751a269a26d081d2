"""Progress drawn where a person watches (see :mod:`ipyros.core.progress`): a rich bar in a terminal, one line
redrawn in place in Jupyter, nothing when the output is not a terminal (a pipe, a file, a test's capture).

The extension gives the session :func:`view` as it loads; the work calls it without knowing where it runs. A view
appears only once the work has run :data:`DELAY` seconds, redraws at most :data:`REDRAW` times a second, whatever
the work tells it, and is gone when the work ends.
"""

from __future__ import annotations

import contextlib
import sys
import threading
import time
from typing import Any, Callable, Iterator, Optional

from ..core.progress import Step, Tally, no_progress
from .magics.cell_output import in_kernel

__all__ = ["DELAY", "REDRAW", "view"]

#: Redraws a second, at most.
REDRAW = 4.0
#: Work shorter than this shows no progress at all (s).
DELAY = 1.0


def view(shell: Any) -> Any:
    """The session's ``progress`` for ``shell``: where its output goes decides, at each piece of work."""

    @contextlib.contextmanager
    def progress(what: str, total: Optional[float] = None, unit: str = "") -> Iterator[Step]:
        if in_kernel(shell):
            with _in_jupyter(what, total, unit) as step:
                yield step
        elif _terminal():
            with _in_terminal(what, total, unit) as step:
                yield step
        else:
            with no_progress(what, total, unit) as step:
                yield step

    return progress


def _terminal() -> bool:
    try:
        return sys.stdout.isatty()
    except (AttributeError, ValueError):
        return False


@contextlib.contextmanager
def _in_terminal(what: str, total: Optional[float], unit: str) -> Iterator[Step]:
    from rich.progress import BarColumn, Progress, ProgressColumn, TextColumn, TimeElapsedColumn, TimeRemainingColumn
    from rich.text import Text

    class Rate(ProgressColumn):
        def render(self, task: Any) -> Text:
            return Text(f"{task.speed:,.0f}/s" if task.speed else "")

    done = "{task.completed:,.0f}/{task.total:,.0f}" if total else "{task.completed:,.0f}"
    columns = (TextColumn("{task.description}"), BarColumn(), TextColumn(f"{done} {unit}"), Rate(),
               TimeRemainingColumn()) if total or unit else (TextColumn("{task.description}"), BarColumn(),
                                                             TimeElapsedColumn())
    bar = Progress(*columns, transient=True, refresh_per_second=REDRAW)
    task = bar.add_task(what, total=total)
    with _shown_after(DELAY, bar.start, bar.stop):
        yield lambda done: bar.update(task, completed=done)


@contextlib.contextmanager
def _in_jupyter(what: str, total: Optional[float], unit: str) -> Iterator[Step]:
    from IPython.display import HTML, display

    tally = Tally(what, total, unit)
    handle = display(HTML(""), display_id=True)  # an empty place, filled once the work has run DELAY seconds
    last = [0.0]
    shown = [False]

    def show() -> None:
        shown[0] = True
        handle.update(HTML(_html(tally)))

    def step(done: float) -> None:
        tally.done = done
        now = time.monotonic()
        if shown[0] and now - last[0] >= 1 / REDRAW:
            last[0] = now
            handle.update(HTML(_html(tally)))

    with _shown_after(DELAY, show, lambda: handle.update(HTML("")) if shown[0] else None):  # gone when done
        yield step


@contextlib.contextmanager
def _shown_after(delay: float, show: Callable[[], None], hide: Callable[[], None]) -> Iterator[None]:
    """``show()`` once the block has run ``delay`` seconds (work of a moment shows nothing), ``hide()`` at its end."""
    lock = threading.Lock()
    state = {"shown": False, "over": False}

    def later() -> None:
        with lock:
            if not state["over"]:
                state["shown"] = True
                show()

    timer = threading.Timer(delay, later)
    timer.daemon = True
    timer.start()
    try:
        yield
    finally:
        timer.cancel()
        with lock:
            state["over"] = True
            if state["shown"]:
                hide()


def _html(tally: Tally) -> str:
    import html

    share = f'<progress value="{tally.done:.0f}" max="{tally.total:.0f}"></progress> ' if tally.total else ""
    return f"<div style='font-family: monospace'>{share}{html.escape(tally.line())}</div>"
