"""Where the magics' output goes: rich or plain, and safe from ROS callback threads.

Two rules make output behave in every front end:

* Look up ``sys.stdout``/``sys.stderr`` at each write, never keep them. The terminal
  IPython swaps them for prompt_toolkit's proxies while it shows the prompt (so that a
  line printed by a ROS callback lands *above* the prompt instead of through it), and a
  kernel routes them to the cell that is running.
* Write a report in one ``write`` call, so that lines from two threads do not interleave.

rich does the rest: a ``Console`` made at print time colours only a terminal, writes plain
text to a pipe, and in Jupyter emits the table as HTML.
"""

from __future__ import annotations

import logging
import sys
from typing import Any, Callable

from rich.console import Console
from rich.protocol import rich_cast
from rich.table import Table

from ..display import render_plain, table_html

from ..slots import HandlerFailure


class Printer:
    """Prints renderables the way the settings say: rich (``rich_output``) or plain text."""

    def __init__(self, rich_output: Callable[[], bool]) -> None:
        self._rich = rich_output  # read at each print: %config may change it any time

    def console(self) -> Console:
        if self._rich():
            return Console(file=sys.stdout)  # auto: colour in a terminal, HTML in Jupyter, plain in a pipe
        return Console(file=sys.stdout, color_system=None, force_jupyter=False, highlight=False, emoji=False)

    def show(self, *renderables: Any) -> None:
        """Print tables, rich markup strings or anything rich can render; in Jupyter a table as HTML."""
        console = self.console()
        for renderable in renderables:
            table = rich_cast(renderable)
            if console.is_jupyter and isinstance(table, Table):
                from IPython.display import display

                display({"text/plain": render_plain(table), "text/html": table_html(table)}, raw=True)
            else:
                console.print(renderable)

    def text(self, renderable: Any) -> str:
        """``renderable`` as plain text (no colour), e.g. to put inside a one-line message."""
        return render_plain(renderable)


def note(text: str) -> None:
    """One line from ipyros on stderr (from any thread), prefixed ``ipyros:``."""
    _write_err(f"ipyros: {text}\n")


def note_line(text: str) -> None:
    """A message that already says ``ipyros:`` (a basenode died, ...), on stderr from any thread."""
    _write_err(text.rstrip("\n") + "\n")


def failure_report(tracebacks: Callable[[], bool]) -> Callable[[HandlerFailure], None]:
    """A ``Session.report`` that prints a failing handler's traceback (or one line) safely.

    Called on the ROS thread that ran the handler; the node keeps running.
    """

    def report(failure: HandlerFailure) -> None:
        more = f" ({failure.suppressed} more failures since the last report)" if failure.suppressed else ""
        head = f"ipyros: handler {failure.handler} failed on {failure.label}{more}; the node keeps running"
        if tracebacks():
            _write_err(f"{head}\n{failure.traceback.rstrip()}\n")
        else:
            error = failure.error
            _write_err(f"{head}: {type(error).__name__}: {error}\n")

    return report


def _write_err(text: str) -> None:
    stream = sys.stderr
    if stream is None:  # pythonw and friends
        return
    stream.write(text)
    stream.flush()


class StderrLogHandler(logging.StreamHandler):
    """A log handler writing to the *current* ``sys.stderr`` (see the module docstring)."""

    def __init__(self) -> None:
        super().__init__()
        self.setFormatter(logging.Formatter("ipyros %(levelname)s %(name)s: %(message)s"))

    @property  # type: ignore[override]
    def stream(self):
        return sys.stderr

    @stream.setter
    def stream(self, value) -> None:  # StreamHandler.__init__ sets it; we always use sys.stderr
        pass
