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

import itertools
from html import escape
import logging
import sys
import time
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

    def repeat(self, render: Callable[[float], Any], period: float, times: int = 0) -> None:
        """Show ``render(seconds so far)`` every ``period`` seconds, ``times`` times (0: until Ctrl-C).

        Redrawn in place where the front end can: a terminal (rich's Live), Jupyter (a display
        updated by its id). Anywhere else (a pipe) only the last one is printed, when it stops.
        """
        console = self.console()
        start = time.monotonic()
        live: Any = None
        if console.is_terminal:
            from rich.live import Live

            live = Live(console=console, auto_refresh=False)
            live.start()
        elif console.is_jupyter:
            from IPython.display import display

            live = display({"text/plain": ""}, raw=True, display_id=True)
        shown = None
        try:
            for done in itertools.count(1):
                time.sleep(max(0.0, start + done * period - time.monotonic()))
                shown = render(time.monotonic() - start)
                if live is not None:
                    self._redraw(live, shown)
                if times and done >= times:
                    break
        except KeyboardInterrupt:
            pass
        finally:
            if live is not None and hasattr(live, "stop"):
                live.stop()
        if live is None and shown is not None:
            self.show(shown)

    @staticmethod
    def _redraw(live: Any, renderable: Any) -> None:
        if hasattr(live, "stop"):  # rich's Live
            live.update(renderable, refresh=True)
            return
        table = rich_cast(renderable)
        html = table_html(table) if isinstance(table, Table) else f"<pre>{escape(render_plain(renderable))}</pre>"
        live.update({"text/plain": render_plain(renderable), "text/html": html}, raw=True)

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
