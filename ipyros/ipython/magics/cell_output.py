"""In Jupyter, what a node's handlers print stays below the cell that created the node.

A handler runs on a ROS thread. What it prints goes to ``sys.stdout``, which the kernel
sends to whichever cell runs at that moment (or ran last): a node created in cell 3
would scatter its prints over cells 4, 5 and 6, and a node printing at 10 Hz would make
every later cell unreadable. So, in a kernel only:

* the extension routes ``sys.stdout`` and ``sys.stderr`` (:mod:`ipyros.core.streams`): text
  written by a thread that is running a handler goes to that handler's node's
  :class:`OutputArea`; any other text passes through unchanged;
* each node created from a cell gets an :class:`OutputArea`: an output of that cell with a
  display id, redrawn in place (at most a few times a second) with the last lines written
  to it. A front end updates a display by its id whichever cell runs now, so the text
  stays with its node; ``%echo`` uses the same rolling view.

:class:`NodeOutput` is the node's :class:`ipyros.core.slots.OutputScope`: the slot enters it
around each handler call, so the handler's failure reports go to the same place.
"""

from __future__ import annotations

import html
import threading
from collections import deque
from typing import Any

from ...core import streams


class OutputArea:
    """An output below the cell that made it, showing the last ``lines`` lines written to it."""

    def __init__(self, lines: int = 200, interval: float = 0.25) -> None:
        from IPython.display import display

        self._lines: deque[str] = deque(maxlen=lines)
        self._partial = ""  # a line not ended yet: print writes its text and its newline apart
        self._interval = interval
        self._lock = threading.Lock()
        self._pending = False
        self.written = 0  # lines so far, kept or not
        self._handle = display(self._bundle(""), raw=True, display_id=True)

    def write(self, text: str) -> int:
        with self._lock:
            *ended, self._partial = (self._partial + text).split("\n")
            self._lines.extend(ended)
            self.written += len(ended)
            if self._pending:
                return len(text)
            self._pending = True
        timer = threading.Timer(self._interval, self.flush)
        timer.daemon = True
        timer.start()
        return len(text)

    def flush(self) -> None:
        """Redraw the area now with what it holds."""
        with self._lock:
            self._pending = False
            lines = list(self._lines) + ([self._partial] if self._partial else [])
            hidden = self.written - len(self._lines)
        text = "\n".join(([f"... ({hidden} earlier lines not shown)"] if hidden else []) + lines)
        self._handle.update(self._bundle(text), raw=True)

    @staticmethod
    def _bundle(text: str) -> dict[str, str]:
        shown = f'<pre style="max-height:24em;overflow:auto">{html.escape(text)}</pre>' if text else ""
        return {"text/plain": text, "text/html": shown}


class NodeOutput:
    """Where a node's handler calls write: entered by the slot around each call (``OutputScope``)."""

    def __init__(self, area: OutputArea) -> None:
        self.area = area

    def enter(self) -> Any:
        return streams.enter(self.area)

    def leave(self, previous: Any) -> None:
        streams.leave(previous)


def in_kernel(shell: Any) -> bool:
    """Whether ``shell`` is a Jupyter kernel's (its output goes to cells, not to a terminal)."""
    return getattr(shell, "kernel", None) is not None


__all__ = ["NodeOutput", "OutputArea", "in_kernel"]
