"""``%hz``, ``%bw``, ``%delay``: what ``rostopic hz/bw/delay`` measure, on several topics at once.

    %hz /turtle1/pose /turtle1/cmd_vel          rates, redrawn every second until Ctrl-C
    %hz /scan -n 1 -w 5                         one report, after listening 5 s
    %bw /camera/image_raw                       bytes per second
    %delay /scan                                now - header.stamp

Each report counts everything since the listening began (as rostopic does), so the
figures settle as it goes on. A latched message sent again to the new listener is not a
publication: it is counted apart, and a topic that only has one says "latched". The
listening node is removed when the magic ends. ``%topics --hz`` takes one quick look.
"""

from __future__ import annotations

from typing import Callable, Optional

from IPython.core.error import UsageError
from IPython.core.magic import line_magic, magics_class
from IPython.core.magic_arguments import magic_arguments, parse_argstring
from rich.table import Table

from ...tools.probe import Rate, RateMeter
from ..api import global_topic, live_graph, live_type
from ..arguments import TOPIC, argument
from .common import ExtensionMagics

#: A report's column names after "topic", and the cells of a row from (type, rate or None, seconds listened).
Columns = tuple[tuple[str, ...], Callable[[str, Optional[Rate], float], list[str]]]


def _hz_cells(type_name: str, rate: Optional[Rate], listened: float) -> list[str]:
    if rate is None:
        return ["0", f"? ({type_name} not installed)", "", "", ""]
    spread = ["", "", ""] if rate.hz is None else [f"{rate.min_s:.4f}", f"{rate.max_s:.4f}", f"{rate.std_s:.4f}"]
    return [_count(rate), rate.describe(listened), *spread]


def _bw_cells(type_name: str, rate: Optional[Rate], listened: float) -> list[str]:
    if rate is None:
        return ["0", f"? ({type_name} not installed)", "", "", ""]
    low, high, mean = rate.sizes
    flow = _bytes(rate.bytes_per_s) + "/s" if rate.bytes_per_s is not None else rate.describe(listened)
    return [_count(rate), flow, *((_bytes(mean), _bytes(low), _bytes(high)) if rate.count else ("",) * 3)]


def _delay_cells(type_name: str, rate: Optional[Rate], listened: float) -> list[str]:
    if rate is None:
        return ["0", f"? ({type_name} not installed)", "", "", ""]
    if not rate.delays:
        return [_count(rate), "no header.stamp" if rate.count else rate.describe(listened), "", "", ""]
    return [_count(rate), *(f"{value:.4f}" for value in rate.delays)]


HZ: Columns = (("messages", "rate Hz", "min s", "max s", "std dev s"), _hz_cells)
BW: Columns = (("messages", "bandwidth", "mean size", "min size", "max size"), _bw_cells)
DELAY: Columns = (("messages", "mean delay s", "min s", "max s", "std dev s"), _delay_cells)


def _count(rate: Rate) -> str:
    return f"{rate.count}" + (f" (+{rate.replayed} latched)" if rate.replayed else "")


def _bytes(size: float) -> str:
    for unit in ("B", "KB", "MB"):
        if size < 1000 or unit == "MB":
            return f"{size:.0f} {unit}" if unit == "B" else f"{size:.2f} {unit}"
        size /= 1000
    return ""  # not reached


def report(what: str, topics: dict[str, str], rates: dict[str, Optional[Rate]], listened: float,
           where: str, columns: Columns, size_note: Callable[[float], Optional[str]] = lambda size: None) -> Table:
    """The table of one report: a row per topic. ``size_note(size)``: a line to add under the table for
    topics whose largest message is that big (the transport's word on it), or None."""
    names, cells = columns
    table = Table(title=f"{what} over {listened:.1f} s at {where}", title_justify="left")
    # Names stay whole (they are what you copy); %topics shows the types.
    table.add_column("topic", overflow="fold", min_width=min(60, max(map(len, rates), default=5)))
    for name in names:
        table.add_column(name, justify="right")
    for topic, rate in rates.items():
        table.add_row(topic, *cells(topics[topic], rate, listened))
    captions = []
    if any(rate is not None and rate.hz is None and rate.count for rate in rates.values()):
        captions.append("< N: one message per publisher so far; listen longer for a rate")
    large = [topic for topic, rate in rates.items() if rate is not None and rate.count and size_note(rate.sizes[1])]
    if large:
        largest = max(rates[topic].sizes[1] for topic in large)  # type: ignore[union-attr]
        captions.append(f"{', '.join(large)}: {size_note(largest)}")
    if captions:
        table.caption = "\n".join(captions)
        table.caption_justify = "left"
    return table


def _options(topics: str) -> Callable[[Callable[..., None]], Callable[..., None]]:
    """The arguments of %hz, %bw and %delay, defined once."""
    def decorate(magic: Callable[..., None]) -> Callable[..., None]:
        magic = argument("-n", "--count", type=int, default=0,
                         help="stop after this many reports (default: until Ctrl-C)")(magic)
        magic = argument("-w", "--window", type=float, default=1.0,
                         help="report every this many seconds (default 1)")(magic)
        magic = argument("topic", nargs="+", complete=TOPIC, help=topics)(magic)
        return magic_arguments()(magic)
    return decorate


@magics_class
class RateMagics(ExtensionMagics):
    """Magics that measure live topics as messages arrive."""

    def _measure(self, line: str, magic: Callable[..., None], what: str, columns: Columns) -> None:
        args = parse_argstring(magic, line)
        if not 0.05 <= args.window <= 600:
            raise UsageError(f"-w must be between 0.05 and 600 seconds, not {args.window}")
        if args.count < 0:
            raise UsageError(f"-n must be 0 (until Ctrl-C) or more, not {args.count}")
        snap = live_graph(self.ext)  # one read of the graph for every topic
        topics = {topic: live_type(self.ext, topic, snap=snap) for topic in map(global_topic, args.topic)}
        where = self.ext.graph.where
        with RateMeter(topics) as meter:
            note = self.ext.session.backend.size_note if columns is BW else (lambda size: None)
            self.ext.printer.repeat(lambda listened: report(what, topics, meter.rates(), listened, where, columns,
                                                            note), args.window, args.count)

    @_options("the live topics to measure, together")
    @line_magic
    def hz(self, line: str) -> None:
        """The message rate of each TOPIC, as rostopic hz measures it, redrawn until Ctrl-C (or -n reports):
        the mean rate, and the shortest, longest and spread of the intervals between messages."""
        self._measure(line, self.hz, "rates", HZ)

    @_options("the live topics to measure, together")
    @line_magic
    def bw(self, line: str) -> None:
        """The bandwidth of each TOPIC (bytes on the wire per second) and its message sizes, as rostopic bw
        measures them, redrawn until Ctrl-C (or -n reports)."""
        self._measure(line, self.bw, "bandwidth", BW)

    @_options("the live topics to measure, together; their messages have a header")
    @line_magic
    def delay(self, line: str) -> None:
        """How late the messages of each TOPIC arrive (now - header.stamp, wall clock), as rostopic delay
        measures it, redrawn until Ctrl-C (or -n reports)."""
        self._measure(line, self.delay, "delays", DELAY)


__all__ = ["RateMagics", "report"]
