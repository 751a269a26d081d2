"""Rich renderables for nodes and their status, and how to print them anywhere.

Renderables are built from plain data (the model, slot figures) and never from rospy,
so they look the same in a terminal, in a notebook (as HTML) and in plain text.
"""

from __future__ import annotations

import html
import io
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from rich.console import Console
from rich.markup import escape
from rich.protocol import rich_cast
from rich.table import Table
from rich.text import Text

from ..core.qos import from_model as qos_of

if TYPE_CHECKING:
    from ..node.dsl import rosNode


def node_table(node: "rosNode") -> Table:
    """The node's declared structure: one row per topic, timer, service and parameter."""
    model = node.model()
    state = "[green]running[/]" if node.created else "[yellow]declared[/]"
    title = f"rosNode [bold]{node.fullname}[/] ({state})"
    if model.base is not None:
        title += f" wrapping [bold]{model.base.package or '?'}/{model.base.executable or '?'}[/]"
    table = Table(title=title, title_justify="left", show_lines=False)
    for column in ("kind", "name", "type", "role", "handler"):
        table.add_column(column)
    for t in model.topics:
        kind = t.direction + (" (latched)" if t.latch else "") + (f" ({qos_of(t.qos)})" if t.qos else "")
        table.add_row(kind, t.resolved, t.type, t.role, t.handler or "")
    for s in model.services:
        table.add_row("service", s.resolved, s.type, s.role, s.handler or "")
    for timer in model.timers:
        table.add_row("timer", timer.name, f"every {timer.period:g} s" + (" once" if timer.oneshot else ""),
                      "new", timer.handler)
    for key, value in model.params.items():
        table.add_row("param", f"~{key}", repr(value), "", "")
    if not table.row_count:
        table.add_row("", "[dim]nothing declared yet[/]", "", "", "")
    return table


class Shown:
    """Shows itself as its rich rendering: in a terminal as text, in Jupyter as HTML."""

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        # IPython's pretty printer takes the first class of the MRO that has _repr_pretty_ or
        # __repr__ of its own; a dataclass has its own __repr__, so it gets _repr_pretty_ too.
        cls._repr_pretty_ = Shown._repr_pretty_  # type: ignore[method-assign]

    def _repr_pretty_(self, printer: Any, cycle: bool) -> None:
        printer.text(render_text(self))

    def _repr_html_(self) -> str:
        return render_html(self)


class Rows(Shown):
    """A sequence of records (``rows``) shown as a table."""

    rows: tuple[Any, ...]

    def __len__(self) -> int:
        return len(self.rows)

    def __iter__(self):  # type: ignore[no-untyped-def]
        return iter(self.rows)

    def __getitem__(self, index: int) -> Any:
        return self.rows[index]


@dataclass(frozen=True)
class StatusRow:
    """One line of a node's status: a handler (subscription, timer, service) or a topic it sends on.

    For a handler ``calls`` counts its calls; for a publication or relay (no handler, no
    timing) the messages sent, to ``connections`` subscribers, of which slow ones have
    ``waiting`` messages queued and lost ``dropped`` so far.
    """

    kind: str
    name: str
    handler: str
    calls: int
    rate_hz: float = 0.0
    mean_ms: float = 0.0
    max_ms: float = 0.0
    errors: int = 0
    connections: int = 0
    waiting: int = 0
    dropped: int = 0


@dataclass(frozen=True)
class NodeStatus(Shown):
    """Per handler and per topic sent on: calls, rate, handler time, exceptions, drops; rich-renderable."""

    node: str
    running: bool
    rows: tuple[StatusRow, ...]
    params: tuple[tuple[str, str], ...] = ()  # the node's own parameters as they are now (set from outside too)

    @classmethod
    def of(cls, node: "rosNode") -> "NodeStatus":
        rows = []
        for key, slot in sorted(node.slots().items()):
            kind, name = key.split(" ", 1)
            f = slot.figures()
            rows.append(StatusRow(kind, name, getattr(slot.handler, "__name__", "?"), f.calls, f.rate_hz,
                                  f.mean_ms, f.max_ms, f.errors))
        for sent in node.sent():
            rows.append(StatusRow(sent.kind, sent.topic, "", sent.messages, connections=sent.connections,
                                  waiting=sent.waiting, dropped=sent.dropped))
        params = tuple((f"~{key}", repr(value)) for key, value in node.params.items()) if node.created else ()
        return cls(node.fullname, node.created, tuple(rows), params)

    def row(self, name: str) -> StatusRow:
        return next(r for r in self.rows if r.name == name)

    def __rich__(self) -> Table:
        table = Table(title=f"status of {self.node}" + ("" if self.running else " (not running)"),
                      title_justify="left")
        for column, justify in (("kind", "left"), ("name", "left"), ("handler", "left"), ("calls", "right"),
                                ("rate Hz", "right"), ("mean ms", "right"), ("max ms", "right"),
                                ("errors", "right"), ("subscribers", "right"), ("dropped", "right")):
            table.add_column(column, justify=justify)  # type: ignore[arg-type]
        for r in self.rows:
            errors = f"[red]{r.errors}[/]" if r.errors else "0"
            if r.handler:
                timing = (f"{r.rate_hz:.1f}", f"{r.mean_ms:.3f}", f"{r.max_ms:.3f}", errors, "", "")
            else:  # a topic sent on: who gets it, and what slow subscribers lost
                waiting = f" ({r.waiting} waiting)" if r.waiting else ""
                dropped = f"[red]{r.dropped}[/]{waiting}" if r.dropped else f"0{waiting}"
                timing = ("", "", "", "", str(r.connections), dropped)
            table.add_row(r.kind, r.name, r.handler, str(r.calls), *timing)
        for name, value in self.params:
            table.add_row("param", name, value, *[""] * 7)
        return table


@dataclass(frozen=True)
class History(Rows):
    """A node's changes, oldest first (``ipyros.node.session.Change``); rich-renderable."""

    node: str
    rows: tuple[Any, ...]
    path: Any = None  # the file the session writes its history to, if any

    def __rich__(self) -> Table:
        import time

        kept = f" (kept in {self.path})" if self.path else ""
        table = Table(title=f"history of {self.node}{kept}", title_justify="left")
        table.add_column("#", justify="right")
        table.add_column("time")
        table.add_column("change", overflow="fold")
        for i, change in enumerate(self.rows, 1):
            table.add_row(str(i), time.strftime("%H:%M:%S", time.localtime(change.time)), change.change)
        return table


def render_text(renderable: Any, width: int = 100) -> str:
    """Render to a string: colours only when stdout is a terminal."""
    import sys

    buffer = io.StringIO()
    console = Console(file=buffer, width=_width(width), force_terminal=sys.stdout.isatty(), force_jupyter=False,
                      color_system="auto" if sys.stdout.isatty() else None)
    console.print(renderable)
    return buffer.getvalue().rstrip("\n")


def render_html(renderable: Any) -> str:
    """Render as an HTML fragment for Jupyter: a table as an HTML table, anything else as coloured text."""
    table = rich_cast(renderable)
    if isinstance(table, Table):
        return table_html(table)
    console = Console(record=True, file=io.StringIO(), width=120, force_jupyter=False)
    console.print(renderable)
    return console.export_html(inline_styles=True, code_format="<pre style=\"font-family:monospace\">{code}</pre>")


def table_html(table: Table) -> str:
    """A rich :class:`Table` as an HTML ``<table>``, its markup (colours, bold) as inline styles.

    rich's own Jupyter output is the terminal drawing in a ``<pre>``: box characters that
    wrap on a narrow page and copy badly. A notebook styles a real table as its own.
    """
    console = Console(file=io.StringIO(), color_system="truecolor", force_jupyter=False, width=10_000)

    def cell(value: Any) -> str:
        if isinstance(value, str):
            value = Text.from_markup(value)
        if not isinstance(value, Text):  # another renderable: its text, as the terminal would show it
            value = Text("\n".join(line.rstrip() for line in render_plain(value).splitlines()))
        parts = []
        for segment in value.render(console):
            text = html.escape(segment.text).replace("\n", "<br>")
            css = segment.style.get_html_style() if segment.style else ""
            parts.append(f'<span style="{css}">{text}</span>' if css else text)
        return "".join(parts)

    def align(column: Any) -> str:
        return f' style="text-align:{column.justify}"' if column.justify in ("right", "center") else ""

    head = "".join(f"<th{align(c)}>{cell(c.header)}</th>" for c in table.columns)
    columns = [list(c.cells) for c in table.columns]
    body = "".join("<tr>" + "".join(f"<td{align(c)}>{cell(cells[row])}</td>" for c, cells in zip(table.columns, columns))
                   + "</tr>" for row in range(table.row_count))
    caption = f'<caption style="text-align:left">{cell(table.title)}</caption>' if table.title else ""
    note = f'<p style="text-align:left">{cell(table.caption)}</p>' if table.caption else ""
    return f'<table class="ipyros">{caption}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>{note}'


def render_plain(renderable: Any) -> str:
    """``renderable`` as plain text, without colour or width limit (e.g. inside a one-line message)."""
    buffer = io.StringIO()
    Console(file=buffer, color_system=None, force_jupyter=False, width=10_000).print(renderable)
    return buffer.getvalue().rstrip("\n")


def _width(default: int) -> int:
    import shutil

    return max(60, shutil.get_terminal_size((default, 24)).columns)


@dataclass(frozen=True)
class Versions(Rows):
    """The versions of one handler (``ipyros.core.versions.HandlerVersion``), oldest first; rich-renderable."""

    label: str  # e.g. "kobuki /cmd_vel"
    rows: tuple[Any, ...]
    current: Any  # the number of the version serving now, or None

    def __rich__(self) -> Table:
        table = Table(title=f"versions of the handler of {self.label}", title_justify="left")
        for column in ("#", "time", "handler", "lines", "first line of its body"):
            table.add_column(column, justify="right" if column in ("#", "lines") else "left", overflow="fold")
        for v in self.rows:
            mark = " (now)" if v.number == self.current else ""
            lines = [line.strip() for line in (v.source or "").splitlines() if line.strip()]
            body = next((line for line in lines[1:] if not line.startswith(("#", '"""', "'''"))),
                        lines[0] if lines else "no source")
            table.add_row(f"{v.number}{mark}", v.when, v.name, str(len(lines)), escape(body))
        if not self.rows:
            table.add_row("", "", "no versions yet", "", "")
        return table


__all__ = ["History", "Versions", "NodeStatus", "StatusRow", "node_table", "render_text", "render_html",
           "render_plain", "table_html"]
