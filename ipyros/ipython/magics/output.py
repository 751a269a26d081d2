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
import logging
import sys
import time
from typing import Any, Callable, Optional

from rich.console import Console
from rich.protocol import rich_cast
from rich.table import Table

from ...core.slots import HandlerFailure
from ..display import is_large, render_html, render_plain, renderable, table_text


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
        for shown in renderables:
            shown = renderable(shown)  # a record's table (see ipyros.ipython.display)
            if is_large(shown) and not console.is_jupyter:  # rich would take seconds to lay it out
                sys.stdout.write(table_text(rich_cast(shown)) + "\n")
            elif console.is_jupyter and isinstance(rich_cast(shown), Table):
                from IPython.display import display

                display(mime_bundle(shown), raw=True)
            else:
                console.print(shown)

    def repeat(self, render: Callable[[float], Any], period: float, times: int = 0,
               until: Optional[Callable[[], bool]] = None) -> bool:
        """Show ``render(seconds so far)`` every ``period`` seconds, ``times`` times (0: until Ctrl-C)
        or until ``until()`` is true; True if Ctrl-C ended it.

        Redrawn in place where the front end can: a terminal (rich's Live), Jupyter (a display
        updated by its id). Anywhere else (a pipe) only the last one is printed, when it stops.
        """
        console = self.console()
        redraw: Optional[Callable[[Any], None]] = None
        stop: Callable[[], None] = lambda: None  # noqa: E731
        if console.is_terminal:
            from rich.live import Live

            live = Live(console=console, auto_refresh=False)
            live.start()
            redraw, stop = (lambda shown: live.update(shown, refresh=True)), live.stop
        elif console.is_jupyter:
            from IPython.display import display

            handle = display({"text/plain": ""}, raw=True, display_id=True)
            redraw = lambda shown: handle.update(mime_bundle(shown), raw=True)  # noqa: E731
        start, shown, interrupted = time.monotonic(), None, False
        try:
            for done in itertools.count(1):
                time.sleep(max(0.0, start + done * period - time.monotonic()))
                finished = until is not None and until()  # before rendering: the last view shows the end
                shown = render(time.monotonic() - start)
                if redraw is not None:
                    redraw(shown)
                if times and done >= times or finished:
                    break
        except KeyboardInterrupt:
            interrupted = True
        finally:
            stop()
        if redraw is None and shown is not None:
            self.show(shown)
        return interrupted

    def text(self, renderable: Any) -> str:
        """``renderable`` as plain text (no colour), e.g. to put inside a one-line message."""
        return render_plain(renderable)


def mime_bundle(renderable: Any) -> dict[str, str]:
    """``renderable`` for Jupyter: HTML (a table as an HTML table), with plain text beside it."""
    return {"text/plain": render_plain(renderable), "text/html": render_html(renderable)}


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
