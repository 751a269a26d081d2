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
from typing import Any, Mapping, Optional, Sequence

from ..core import msgpath, msgtypes
from ..core.errors import IpyrosError
from ..core.names import tool_name
from ..core.text import counted
from ..dsl import rosNode

__all__ = ["Plot", "Series", "figure", "series_chart", "series_figure", "text_chart"]


class Plot:
    """The values of ``fields`` (dotted paths: ``linear.x``) of the messages on ``topic``, over time; ``others``
    ({topic: (type, fields)}) adds fields of more topics, each on its own arrival times.

    ``xy``: the two fields are a trajectory (x, y), drawn against each other, not over time.
    """

    def __init__(self, topic: str, type_name: str, fields: Sequence[str], xy: bool = False,
                 window: float = 30.0, others: Optional[Mapping[str, tuple[str, Sequence[str]]]] = None) -> None:
        streams = {topic: (type_name, list(fields)), **dict(others or {})}
        if not all(f for _, f in streams.values()):
            raise IpyrosError(f"%plot {topic}: name the fields to plot, e.g. linear.x angular.z")
        if importlib.util.find_spec("numpy") is None or importlib.util.find_spec("matplotlib") is None:
            raise IpyrosError("%plot needs numpy and matplotlib: pip install 'ipyros[plot]' (bash run.sh has them)")
        if xy and (len(fields) != 2 or len(streams) > 1):
            raise IpyrosError(f"--xy draws one field against another of one topic: give two fields, not "
                              f"{sum(len(f) for _, f in streams.values())}")
        for name, (kind, paths) in streams.items():  # a field its type lacks, or no number: said before any message
            cls = msgtypes.message_class_or_none(kind)
            for path in paths:
                msgpath.parse(f"{name}.{path}").check_number(cls)
        self.topic, self.type_name, self.xy, self.window = topic, type_name, xy, window
        self.topics = list(streams)
        self._fields = {t: f for t, (_, f) in streams.items()}
        #: The series, as ``data`` names them: a field alone for one topic, ``topic.field`` for several.
        self.fields = list(fields) if len(streams) == 1 else [f"{t}.{f}" for t, fs in self._fields.items() for f in fs]
        self._samples: dict[str, deque[tuple[float, tuple[float, ...]]]] = {t: deque() for t in streams}
        self._lock = threading.Lock()
        self._t0 = time.monotonic()
        self.problem: Optional[str] = None  # why recording stopped early (a field that is not a number)
        self._node: Optional[rosNode] = rosNode(tool_name("plot"))
        for name, (kind, _) in streams.items():
            self._node.new.subscribe(name, handler=lambda msg, name=name: self._record(name, msg), msgType=kind)
        self._node.create()

    # -- recording (on the executor's thread) ------------------------------------------
    def _record(self, topic: str, msg: Any) -> None:
        try:
            values = tuple(float(_field(msg, path)) for path in self._fields[topic])
        except (AttributeError, TypeError, ValueError) as error:
            self.problem = f"%plot {topic}: {error}"
            return
        now = time.monotonic() - self._t0
        with self._lock:
            samples = self._samples[topic]
            samples.append((now, values))
            while samples and samples[0][0] < now - self.window:
                samples.popleft()

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
        """``{"t": times, field: values, ...}`` as numpy arrays, a copy: the last ``window`` seconds. With several
        topics each field is ``topic.field`` and its times ``"t topic"`` (``"t"`` the first topic's)."""
        import numpy as np

        with self._lock:
            taken = {topic: list(samples) for topic, samples in self._samples.items()}
        columns = {"t": np.array([t for t, _ in taken[self.topic]])}
        for topic, samples in taken.items():
            if len(taken) > 1:
                columns[f"t {topic}"] = np.array([t for t, _ in samples])
            for i, path in enumerate(self._fields[topic]):
                columns[path if len(taken) == 1 else f"{topic}.{path}"] = np.array([v[i] for _, v in samples])
        return columns

    def series(self) -> list[tuple[str, Any, Any]]:
        """``(label, times, values)`` of each field, for a chart."""
        data = self.data
        if len(self.topics) == 1:
            return [(path, data["t"], data[path]) for path in self.fields]
        return [(f"{t}.{f}", data[f"t {t}"], data[f"{t}.{f}"]) for t, fs in self._fields.items() for f in fs]

    def __len__(self) -> int:
        return sum(len(samples) for samples in self._samples.values())

    def __repr__(self) -> str:
        what = ", ".join(self.fields) if len(self.topics) > 1 else f"{self.topic} {', '.join(self.fields)}"
        if self.running:  # shown once, while the count still grows: a number here would be stale at once
            return f"<Plot of {what} (recording): .data holds the samples as arrays>"
        return f"<Plot of {what} (stopped): {counted(len(self), 'sample')}; .data holds them as arrays>"


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

#: One line of a chart: its label, its x values and its y values (lists or numpy arrays of one length).
Series = tuple[str, Sequence[float], Sequence[float]]


def figure(plot: Plot) -> Any:
    """A matplotlib figure of the plot's data now (Agg: no display needed)."""
    data = plot.data
    title = f"{', '.join(plot.topics)} ({counted(len(plot), 'message')})"
    if plot.xy:
        x, y = plot.fields
        return series_figure(title, [(y, data[x], data[y])], x, xy=True)
    return series_figure(title, plot.series(), "time (s)")


def series_figure(title: str, series: Sequence[Series], x_label: str, xy: bool = False) -> Any:
    """A matplotlib figure of ``series`` against x (Agg: no display needed); ``xy``: one trajectory, equal axes."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7, 3.5) if not xy else (5, 5))
    ax = fig.add_subplot()
    for label, xs, ys in series:
        ax.plot(xs, ys, ".-" if xy else "-", ms=2, lw=0.8 if xy else 1, label=label)
    ax.set_xlabel(x_label)
    if xy:
        ax.set_ylabel(series[0][0])
        ax.set_aspect("equal", adjustable="datalim")
    else:
        ax.legend(loc="upper left", fontsize=8)
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    return fig


_MARKS = "*o+x#@"


def text_chart(plot: Plot, width: int = 72, height: int = 16) -> str:
    """The plot drawn with characters: a frame, the value range on the left, one mark per field."""
    if plot.xy:
        data = plot.data
        x, y = plot.fields
        return series_chart(f"{plot.topic}: {y} vs {x}", [(y, data[x], data[y])], x, width, height, legend=False)
    return series_chart(", ".join(plot.topics), plot.series(), "time (s)", width, height)


def series_chart(title: str, series: Sequence[Series], x_label: str, width: int = 72, height: int = 16,
                 legend: bool = True) -> str:
    """``series`` drawn with characters against a shared x: a frame, the value range on the left, one mark a
    series (named in the title, after ``legend``)."""
    if legend:
        title = f"{title}: " + "  ".join(f"{_MARKS[i % len(_MARKS)]} {label}" for i, (label, _, _) in enumerate(series))
    drawn = [(xs, ys) for _, xs, ys in series if len(xs)]
    if not drawn:
        return f"{title}\n(no message yet)"
    y_low, y_high = min(min(ys) for _, ys in drawn), max(max(ys) for _, ys in drawn)
    x_low, x_high = min(min(xs) for xs, _ in drawn), max(max(xs) for xs, _ in drawn)
    y_low, y_high, x_low, x_high = float(y_low), float(y_high), float(x_low), float(x_high)
    y_span, x_span = (y_high - y_low) or 1.0, (x_high - x_low) or 1.0
    grid = [[" "] * width for _ in range(height)]
    for i, (_, xs, ys) in enumerate(series):
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
    lines += [" " * label + " └" + "─" * width + "┘", " " * (label + 2) + axis, " " * (label + 2) + x_label]
    return "\n".join(lines)
