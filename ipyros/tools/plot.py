"""Live plots of topic fields: the data recorded in the background, and three ways to look at it.

A :class:`Plot` listens to one topic through a small DSL node of its own (as ``%echo``
does) and keeps, for each field asked for, the values of the last ``window`` seconds.
Recording costs one handler call per message on the session's own executor; drawing
happens elsewhere, from a copy, so a plot never slows a node down. After it stops, the
data stays: ``p.data["linear.x"]`` is a numpy array, ``p.data["t"]`` the arrival times
(seconds since the plot started).

Looking at it (:mod:`ipyros.ipython.magics.graph`'s ``%plot`` chooses):

* :func:`text_chart`: a chart drawn with characters, for a terminal;
* :func:`figure`: a matplotlib figure (the Agg renderer), for a PNG or a notebook, where
  ``%plot`` shows it below the cell and redraws it in place while messages flow.
"""

from __future__ import annotations

import importlib.util
import threading
import time
from collections import deque
from typing import Any, Optional, Sequence

from ..core.errors import IpyrosError
from ..core.names import tool_name
from ..core.text import counted
from ..dsl import rosNode

__all__ = ["Plot", "figure", "text_chart"]


class Plot:
    """The values of ``fields`` (dotted paths: ``linear.x``) of the messages on ``topic``, over time.

    ``xy``: the two fields are a trajectory (x, y), drawn against each other, not over time.
    """

    def __init__(self, topic: str, type_name: str, fields: Sequence[str], xy: bool = False,
                 window: float = 30.0) -> None:
        if not fields:
            raise IpyrosError(f"%plot {topic}: name the fields to plot, e.g. linear.x angular.z")
        if importlib.util.find_spec("numpy") is None or importlib.util.find_spec("matplotlib") is None:
            raise IpyrosError("%plot needs numpy and matplotlib: pip install 'ipyros[plot]' (bash run.sh has them)")
        if xy and len(fields) != 2:
            raise IpyrosError(f"--xy draws one field against another: give two fields, not {len(fields)}")
        self.topic, self.type_name, self.fields, self.xy, self.window = topic, type_name, list(fields), xy, window
        self._samples: deque[tuple[float, tuple[float, ...]]] = deque()
        self._lock = threading.Lock()
        self._t0 = time.monotonic()
        self.problem: Optional[str] = None  # why recording stopped early (a field that is not a number)
        self._node: Optional[rosNode] = rosNode(tool_name("plot"))
        self._node.new.subscribe(topic, handler=self._record, msgType=type_name)
        self._node.create()

    # -- recording (on the executor's thread) ------------------------------------------
    def _record(self, msg: Any) -> None:
        try:
            values = tuple(float(_field(msg, path)) for path in self.fields)
        except (AttributeError, TypeError, ValueError) as error:
            self.problem = f"%plot {self.topic}: {error}"
            return
        now = time.monotonic() - self._t0
        with self._lock:
            self._samples.append((now, values))
            while self._samples and self._samples[0][0] < now - self.window:
                self._samples.popleft()

    # -- the data ----------------------------------------------------------------------
    @property
    def running(self) -> bool:
        return self._node is not None

    def stop(self) -> "Plot":
        """Stop listening; the data stays."""
        node, self._node = self._node, None
        if node is not None:
            node.shutdown()
        return self

    @property
    def data(self) -> dict[str, Any]:
        """``{"t": times, field: values, ...}`` as numpy arrays, a copy: the last ``window`` seconds."""
        import numpy as np

        with self._lock:
            samples = list(self._samples)
        columns = {"t": np.array([t for t, _ in samples])}
        for i, path in enumerate(self.fields):
            columns[path] = np.array([values[i] for _, values in samples])
        return columns

    def __len__(self) -> int:
        return len(self._samples)

    def __repr__(self) -> str:
        if self.running:  # shown once, while the count still grows: a number here would be stale at once
            return f"<Plot of {self.topic} {', '.join(self.fields)} (recording): .data holds the samples as arrays>"
        return (f"<Plot of {self.topic} {', '.join(self.fields)} (stopped): {counted(len(self), 'sample')}; "
                ".data holds them as arrays>")


def _field(msg: Any, path: str) -> Any:
    value = msg
    for part in path.split("."):
        if not hasattr(value, part) or part.startswith("_"):
            raise AttributeError(f"no field {path!r} in the messages (at {part!r})")
        value = getattr(value, part)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TypeError(f"field {path} is a {type(value).__name__}, not a number: plot a number field")
    return value


# -- looking at it ---------------------------------------------------------------------------

def figure(plot: Plot) -> Any:
    """A matplotlib figure of the plot's data now (Agg: no display needed)."""
    from matplotlib.figure import Figure

    data = plot.data
    fig = Figure(figsize=(7, 3.5) if not plot.xy else (5, 5))
    ax = fig.add_subplot()
    if plot.xy:
        x, y = plot.fields
        ax.plot(data[x], data[y], ".-", ms=2, lw=0.8)
        ax.set_xlabel(x)
        ax.set_ylabel(y)
        ax.set_aspect("equal", adjustable="datalim")
    else:
        for path in plot.fields:
            ax.plot(data["t"], data[path], lw=1, label=path)
        ax.set_xlabel("time (s)")
        ax.legend(loc="upper left", fontsize=8)
    ax.set_title(f"{plot.topic} ({counted(len(data['t']), 'message')})", fontsize=9)
    fig.tight_layout()
    return fig


_MARKS = "*o+x#@"


def text_chart(plot: Plot, width: int = 72, height: int = 16) -> str:
    """The plot drawn with characters: a frame, the value range on the left, one mark per field."""
    data = plot.data
    xs = data[plot.fields[0]] if plot.xy else data["t"]
    series = [data[plot.fields[1]]] if plot.xy else [data[path] for path in plot.fields]
    title = f"{plot.topic}: " + (" vs ".join(reversed(plot.fields)) if plot.xy else
                                 "  ".join(f"{_MARKS[i % len(_MARKS)]} {p}" for i, p in enumerate(plot.fields)))
    if len(xs) == 0:
        return f"{title}\n(no message yet)"
    lows = [float(min(s.min() for s in series)), float(xs.min())]
    highs = [float(max(s.max() for s in series)), float(xs.max())]
    (y_low, x_low), (y_high, x_high) = lows, highs
    y_span, x_span = (y_high - y_low) or 1.0, (x_high - x_low) or 1.0
    grid = [[" "] * width for _ in range(height)]
    for i, ys in enumerate(series):
        for x, y in zip(xs, ys):
            col = min(width - 1, int((x - x_low) / x_span * (width - 1)))
            row = height - 1 - min(height - 1, int((y - y_low) / y_span * (height - 1)))
            grid[row][col] = _MARKS[i % len(_MARKS)]
    label = max(len(f"{y_high:.3g}"), len(f"{y_low:.3g}"))
    lines = [title, " " * label + " ┌" + "─" * width + "┐"]
    for r, row in enumerate(grid):
        tick = f"{y_high:.3g}" if r == 0 else f"{y_low:.3g}" if r == height - 1 else ""
        lines.append(f"{tick:>{label}} │{''.join(row)}│")
    axis = f"{x_low:.3g}".ljust(width - len(f"{x_high:.3g}")) + f"{x_high:.3g}"
    lines += [" " * label + " └" + "─" * width + "┘", " " * (label + 2) + axis,
              " " * (label + 2) + (plot.fields[0] if plot.xy else "time (s)")]
    return "\n".join(lines)
