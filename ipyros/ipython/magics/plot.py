"""``%plot``: fields of a live topic drawn while messages flow (:mod:`ipyros.tools.plot` records and draws).

    %plot /turtle1/cmd_vel linear.x angular.z          over time
    %plot /turtle1/pose position.x position.y --xy     a trajectory
    p = %plot /imu linear_acceleration.z --png imu.png --duration 10
    %plot --stop                                       stop the live one (p.data stays)

Where it is drawn: in Jupyter, a figure below the cell, redrawn in place every half
second until ``--duration`` (default 60 s) or ``%plot --stop``, the prompt free
meanwhile; in a terminal, a chart of characters redrawn in place until Ctrl-C (or
``--duration``); with ``--png FILE``, a picture written when the duration is up.
"""

from __future__ import annotations

import io
import re
import threading
import time
from typing import Any, Optional

from IPython.core.error import UsageError
from IPython.core.magic import line_magic, magics_class
from IPython.core.magic_arguments import magic_arguments, parse_argstring

from ...core import msgpath
from ...core.text import counted
from ...tools.plot import Plot, figure, text_chart
from ..api import global_topic, live_type
from ..arguments import FIELD, MSG_PATH, argument
from .common import ExtensionMagics

#: How often a live plot is redrawn (s).
REDRAW = 0.5


def _topic_and_fields(topic: Optional[str], fields: list[str]) -> tuple[Optional[str], list[str], dict[str, list[str]]]:
    """TOPIC FIELD ..., or message paths (``/odom.twist.twist.linear.x /cmd_vel.linear.x``): the first topic, its
    dotted fields, and the other topics' ({topic: fields}). A field after a path is of that path's topic. A plot
    draws fields: an index, a slice or a filter is for %echo."""
    if not topic or not msgpath.is_path(topic):
        return topic, fields, {}
    found: dict[str, list[str]] = {}
    current = ""
    for word in [topic, *fields]:
        if not word.startswith("/"):
            found[current].append(word)
            continue
        path = msgpath.parse(word)
        if not all(isinstance(step, msgpath.Field) for step in path.steps):
            raise UsageError(f"{path.text}: a plot draws number fields; an index, a slice or a filter is for %echo")
        current = path.topic
        found.setdefault(current, []).append(path.field)
    first, *rest = found
    return first, found[first], {name: found[name] for name in rest}


@magics_class
class PlotMagics(ExtensionMagics):
    """The magic that plots topic fields live; one plot is live at a time (``live``)."""

    def __init__(self, shell: Any, ext: Any) -> None:
        super().__init__(shell, ext)
        self.live: Optional[Plot] = None

    def stop_live(self) -> Optional[Plot]:
        """Stop the live plot, if any (``%plot --stop``, and when the extension is unloaded)."""
        stopped, self.live = self.live, None
        return stopped.stop() if stopped is not None else None

    @magic_arguments()
    @argument("topic", nargs="?", complete=MSG_PATH,
              help="the live topic, or a message path into it: /odom.twist.twist.linear.x")
    @argument("fields", nargs="*", complete=FIELD,
              help="its number fields to plot, dotted: linear.x angular.z (or more paths, into other topics too)")
    @argument("--xy", action="store_true", help="two fields drawn against each other: a trajectory")
    @argument("--window", type=float, default=30.0, help="keep (and draw) the last this many seconds (default 30)")
    @argument("--duration", type=float, default=None,
              help="stop after this many seconds (default: Jupyter 60, a terminal until Ctrl-C, --png 5)")
    @argument("--png", metavar="FILE", help="write the plot to this PNG file when the duration is up")
    @argument("--stop", action="store_true", help="stop the live plot")
    @line_magic
    def plot(self, line: str) -> Optional[Plot]:
        """Plot number FIELDS of TOPIC while messages flow; return the Plot (``p.data``: arrays)."""
        args = parse_argstring(self.plot, line)
        if args.stop:
            if args.topic:
                raise UsageError("%plot --stop takes nothing else")
            stopped = self.stop_live()
            print(f"ipyros: stopped plotting {stopped.topic}" if stopped else "ipyros: no plot is live")
            return stopped
        topic, fields, more = _topic_and_fields(args.topic and args.topic.strip("'\""),
                                                [f.strip("'\"") for f in args.fields])
        if not topic or not fields:
            raise UsageError("give a topic and its fields: %plot /turtle1/cmd_vel linear.x angular.z "
                             "(or message paths: %plot /turtle1/cmd_vel.linear.x /turtle1/cmd_vel.angular.z)")
        if not 0 < args.window <= 3600 or (args.duration is not None and not 0 < args.duration <= 86400):
            raise UsageError("--window and --duration are seconds: more than 0 (window up to an hour)")
        topic = global_topic(topic)
        type_name = live_type(self.ext, topic)
        others = {name: (live_type(self.ext, name), words) for name, words in
                  ((global_topic(name), words) for name, words in more.items())}
        self.stop_live()
        plot = Plot(topic, type_name, fields, xy=args.xy, window=args.window, others=others)
        if args.png:
            return self._to_png(plot, args.png, args.duration or 5.0)
        if getattr(self.shell, "kernel", None) is not None:
            return self._in_notebook(plot, args.duration or 60.0)
        return self._in_terminal(plot, args.duration)

    def _to_png(self, plot: Plot, path: str, duration: float) -> Plot:
        try:
            _wait(plot, duration)
        finally:
            plot.stop()
        _check(plot)
        try:
            figure(plot).savefig(path, format="png", dpi=100)
        except OSError as error:
            raise UsageError(f"cannot write {path}: {error.strerror or error}") from None
        print(f"ipyros: {counted(len(plot), 'message')} of {', '.join(plot.topics)} plotted to {path}")
        return plot

    def _in_terminal(self, plot: Plot, duration: Optional[float]) -> Plot:
        from rich.live import Live
        from rich.text import Text

        console = self.ext.printer.console()
        end = time.monotonic() + duration if duration else float("inf")
        try:
            with Live(Text(text_chart(plot)), console=console, auto_refresh=False) as live:
                while time.monotonic() < end and plot.problem is None:
                    time.sleep(REDRAW)
                    live.update(Text(text_chart(plot, width=max(20, console.width - 14))), refresh=True)
        except KeyboardInterrupt:
            pass
        finally:
            plot.stop()
        _check(plot)
        print(f"ipyros: plotted {counted(len(plot), 'message')} of {', '.join(plot.topics)}; "
              f"{self._kept_as()} holds them")
        return plot

    def _kept_as(self) -> str:
        """Where the Plot this line returns lands: ``p.data`` for ``p = %plot ...``, else ``_.data`` (the last
        result) and its ``Out[n]``."""
        source = (self.shell.user_ns.get("In") or [""])[-1]
        assigned = re.match(r"\s*([A-Za-z_]\w*)\s*=\s*(?:%plot|get_ipython\(\)\.run_line_magic\(.plot)", source)
        if assigned:
            return f"{assigned.group(1)}.data"
        return f"_.data (Out[{self.shell.execution_count}].data)"

    def _in_notebook(self, plot: Plot, duration: float) -> Plot:
        from IPython.display import Image, display

        handle = display(Image(data=_png(plot)), display_id=True)
        self.live = plot

        def redraw() -> None:
            end = time.monotonic() + duration
            while plot.running and time.monotonic() < end and plot.problem is None:
                time.sleep(REDRAW)
                handle.update(Image(data=_png(plot)))
            plot.stop()
            handle.update(Image(data=_png(plot)))
            if self.live is plot:
                self.live = None

        threading.Thread(target=redraw, name="ipyros-plot", daemon=True).start()
        return plot


def _png(plot: Plot) -> bytes:
    buffer = io.BytesIO()
    figure(plot).savefig(buffer, format="png", dpi=80)
    return buffer.getvalue()


def _wait(plot: Plot, duration: float) -> None:
    end = time.monotonic() + duration
    try:
        while time.monotonic() < end and plot.problem is None:
            time.sleep(0.05)
    except KeyboardInterrupt:
        pass


def _check(plot: Plot) -> None:
    if plot.problem is not None:
        raise UsageError(plot.problem)
