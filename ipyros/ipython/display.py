"""How ipyros's records look: rich tables, printed as text in a terminal and as HTML tables in Jupyter.

The DSL and the tools return plain records (:mod:`ipyros.core.records`, a node, a demo
robot, a ``%try`` report); this module is the one place that knows how they look. Each
record type has a renderer here (:data:`RENDERERS`); :func:`renderable` finds it,
:func:`render_text` and :func:`render_html` print through it, and :func:`register` gives
them to IPython's display formatters while the extension is loaded, so that ``nd``,
``nd.status()`` or ``nd.history()`` at the prompt shows a table.
"""

from __future__ import annotations

import html
import io
from typing import Any, Callable, Optional

from rich.console import Console, Group
from rich.markup import escape
from rich.protocol import rich_cast
from rich.table import Table
from rich.text import Text

from ..core.errors import IpyrosError
from ..core.graph import GraphSnapshot
from ..core.picture import Picture, to_dot, to_text
from ..core.qos import from_model as qos_of
from ..core.records import History, Interface, NodeStatus, Rows, Versions
from ..core.tables import Cell, TextTable
from ..core.text import counted
from ..dsl import rosNode
from ..tools.drawing import layout
from ..tools.probe import Rate
from ..tools.robot import DemoRobot
from ..tools.tryout import BagTrial, TrialReport, one_line, silent_sides

__all__ = ["LARGE_TABLE", "RENDERERS", "endpoints_table", "interface_table", "is_large", "node_table", "register",
           "render_html", "render_plain", "render_text", "renderable", "rich_table", "session_table", "status_table",
           "table_html", "table_text", "topics_table", "unregister"]


def node_table(node: rosNode) -> Table:
    """The node's declared structure: one row per topic, timer, service and parameter."""
    model = node.model()
    state = "[green]running[/]" if node.created else "[yellow]declared[/]"
    title = f"rosNode [bold]{node.fullname}[/] ({state})"
    if model.base is not None:
        title += f" wrapping [bold]{escape(model.base.describe())}[/]"  # a package's, a file's, a launch file's
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


def session_table(nodes: list[Any], user_ns: dict[str, Any], host: str) -> Table:
    """The rosNodes running in a session, one row each, with the variables that hold them."""
    table = Table(title=f"rosNodes running in this session (hosted by ROS node {host})", title_justify="left")
    for column in ("node", "topics", "timers", "services", "basenode", "variables"):
        table.add_column(column, justify="right" if column in ("topics", "timers", "services") else "left")
    for node in nodes:
        model = node.model()
        base = model.base.describe() if model.base else ""
        names = ", ".join(sorted(k for k, v in user_ns.items() if v is node and not k.startswith("_")))
        counts = (str(len(model.topics)), str(len(model.timers)), str(len(model.services)))
        table.add_row(node.fullname, *counts, base, names)
    return table


def rich_table(table: TextTable, edge: bool = True) -> Table:
    """A record's table (:mod:`ipyros.core.tables`) as a rich one: the same rows, its styled cells coloured."""
    drawn = Table(title=table.title, title_justify="left", show_edge=edge)
    for column in table.columns:
        drawn.add_column(column.name, justify="right" if column.right else "left",
                         overflow="fold" if column.fold else "ellipsis")
    for number, row in enumerate(table.rows):
        if number in table.sections:
            drawn.add_section()
        drawn.add_row(*(Text(cell.text, style=cell.style) if isinstance(cell, Cell) else Text(cell) for cell in row))
    return drawn


def status_table(status: NodeStatus) -> Table:
    """A node's status: one row per handler and per topic it sends on; its parameters under it."""
    return rich_table(status.table())


def history_table(history: History) -> Table:
    """A node's changes, oldest first."""
    return rich_table(history.table())


def robot_table(robot: DemoRobot) -> Table:
    """A demo robot's nodes: what each runs, its remaps, its state now."""
    state = "[green]running[/]" if robot.running else "[yellow]stopped[/]"
    table = Table(title=f"demo robot [bold]{robot.kind}[/] ({state}) from {robot.spec.launch}", title_justify="left")
    for column in ("node", "runs", "remaps", "state"):
        table.add_column(column)
    for row in robot.node_states():
        table.add_row(*row)
    return table


def trial_view(report: TrialReport) -> Group:
    """``%try``: the live handler and the candidate side by side, one row per message, differences marked."""
    summary = (f"{report.differing} of {counted(len(report.rows), 'message')} give different results"
               if report.differing else f"same results on all {counted(len(report.rows), 'message')}")
    names = {"live": report.live_name, "candidate": report.candidate_name}
    silent = silent_sides(report.rows)  # said once, not a column of "(nothing)"
    quiet = f" ({' and '.join(f'{side} {names[side]}' for side in silent)} printed, wrote and raised nothing)" \
        if silent else ""
    heading = Text.assemble((f"{report.node} {report.topic}", "bold"), f": live {report.live_name} vs candidate "
                            f"{report.candidate_name}: ", (summary, "yellow" if report.differing else "green"), quiet)
    table = Table(show_lines=True)
    table.add_column("#", justify="right")
    table.add_column("message", overflow="fold", max_width=40)
    sides = [side for side in names if side not in silent]
    for side in sides:
        table.add_column(f"{side}: {names[side]}", overflow="fold", max_width=60)
    for row in report.rows:
        mark = Text(f"{row.index}" if row.same else f"{row.index} ≠", style="" if row.same else "bold yellow")
        lines = {"live": row.live.lines(), "candidate": row.candidate.lines()}
        other = {"live": "candidate", "candidate": "live"}
        table.add_row(mark, one_line(row.message), *(_outcome(lines[side], lines[other[side]]) for side in sides))
    return Group(heading, table)


def _outcome(lines: list[str], other: list[str]) -> Text:
    """One side of a %try row: the lines the other side does not have stand out."""
    if not lines:
        return Text("(nothing)", style="dim")
    shown = Text()
    for number, line in enumerate(lines):
        shown.append(("\n" if number else "") + line, style="" if line in other else "bold yellow")
    return shown


def interface_table(interface: Interface) -> Table:
    """A rich table of an interface: one row per topic, service or action, with its direction and type."""
    return rich_table(interface.table(), edge=False)


def topics_table(snap: GraphSnapshot, found: list[str], rates: Optional[dict[str, Optional[Rate]]],
                  window: float, where: str) -> Table:
    table = Table(title=f"{len(found)} live topic{'s' * (len(found) != 1)} at {where}", title_justify="left")
    # Names stay whole (they are what you copy); the node lists give way when space runs out.
    table.add_column("topic", overflow="fold", style="bold", min_width=min(60, max(map(len, found), default=5)))
    table.add_column("type", overflow="fold", min_width=min(40, max((len(snap.topics[t] or "?") for t in found),
                                                                   default=4)))
    table.add_column("publishers", overflow="fold")
    table.add_column("subscribers", overflow="fold")
    if rates is not None:
        table.add_column("rate Hz", justify="right")
    for topic in found:
        row = [topic, snap.topics[topic] or "?", _few_nodes(snap.publishers.get(topic, ())),
               _few_nodes(snap.subscribers.get(topic, ()))]
        if rates is not None:
            rate = rates.get(topic)
            row.append(rate.describe(window) if rate is not None else "? (type not installed)")
        table.add_row(*row)
    if rates is not None and any(r is not None and r.hz is None and r.count for r in rates.values()):
        table.caption = f"< N: one message per publisher in {window:g} s; %hz TOPIC listens longer"
        table.caption_justify = "left"
    return table


def endpoints_table(snap: GraphSnapshot, found: list[str], endpoints: Any, where: str) -> Table:
    """``%topics -v``: a row per publisher and subscription of each topic, with its QoS."""
    table = Table(title=f"{len(found)} live topic{'s' * (len(found) != 1)} at {where}, by endpoint",
                  title_justify="left")
    for column in ("topic", "node", "endpoint", "type", "QoS"):  # names and QoS whole; the type gives way
        table.add_column(column, overflow="fold", no_wrap=column != "type", style="bold" if column == "topic" else None)
    for topic in found:
        rows = endpoints(topic) or [("", "", snap.topics[topic] or "?", "")]
        types = {row[2] for row in rows if not row[2].startswith("?")}
        for i, (node, kind, type_name, qos) in enumerate(rows):
            if len(types) > 1:  # ROS connects no two types: say which endpoint hears nothing from which
                type_name = f"[red]{type_name}[/] (not {' or '.join(sorted(types - {type_name}))}: nothing passes)"
            table.add_row(topic if i == 0 else "", node, kind, type_name, qos)
    return table


def _few_nodes(nodes: tuple[str, ...], most: int = 3) -> str:
    shown = ", ".join(nodes[:most])
    return shown + (f" +{len(nodes) - most} more" if len(nodes) > most else "")


def render_text(renderable_: Any, width: int = 100) -> str:
    """Render to a string: colours only when stdout is a terminal."""
    import sys

    renderable_ = renderable(renderable_)
    buffer = io.StringIO()
    console = Console(file=buffer, width=_width(width), force_terminal=sys.stdout.isatty(), force_jupyter=False,
                      color_system="auto" if sys.stdout.isatty() else None)
    console.print(renderable_)
    return buffer.getvalue().rstrip("\n")


#: Above this many rows a table is laid out as aligned plain text (:func:`table_text`), not by rich:
#: rich takes about a millisecond a row (``%topics`` on 1,000 topics: 0.6 s), and a robot's graph
#: has 10,000 topics.
LARGE_TABLE = 200


def is_large(renderable_: Any) -> bool:
    """Whether ``renderable_`` is a table of more than :data:`LARGE_TABLE` rows."""
    table = rich_cast(renderable_)
    return isinstance(table, Table) and table.row_count > LARGE_TABLE


def table_text(table: Table) -> str:
    """``table`` as aligned plain text, a line a row (as ``rostopic list`` prints): no colours, no
    folding, but fast at any size (10,000 rows in a few tens of milliseconds)."""

    def plain(value: Any) -> str:
        if isinstance(value, str):  # only a string with markup pays for parsing it
            return Text.from_markup(value).plain if "[" in value else value
        return value.plain if isinstance(value, Text) else render_plain(value)

    headers = [plain(column.header) for column in table.columns]
    columns = [[plain(cell) for cell in column.cells] for column in table.columns]
    widths = [max([len(header), *map(len, cells)]) for header, cells in zip(headers, columns)]
    right = [column.justify == "right" for column in table.columns]

    def line(cells: Any) -> str:
        return "  ".join(c.rjust(w) if r else c.ljust(w) for c, w, r in zip(cells, widths, right)).rstrip()

    lines = [plain(table.title)] if table.title else []
    lines += [line(headers), line("-" * w for w in widths), *map(line, zip(*columns))]
    if table.caption:
        lines.append(plain(table.caption))
    return "\n".join(lines)


def render_html(renderable_: Any) -> str:
    """Render as an HTML fragment for Jupyter: a table as an HTML table (a large one as preformatted
    text, see :data:`LARGE_TABLE`), anything else as coloured text."""
    renderable_ = renderable(renderable_)
    table = rich_cast(renderable_)
    if is_large(table):
        return f'<pre style="font-family:monospace">{html.escape(table_text(table))}</pre>'
    if isinstance(table, Table):
        return table_html(table)
    console = Console(record=True, file=io.StringIO(), width=120, force_jupyter=False)
    console.print(renderable_)
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

    def align(column: Any) -> str:  # always said: JupyterLab's own style right-aligns every cell
        return f' style="text-align:{column.justify if column.justify in ("right", "center") else "left"}"'

    head = "".join(f"<th{align(c)}>{cell(c.header)}</th>" for c in table.columns)
    columns = [list(c.cells) for c in table.columns]
    body = "".join("<tr>" + "".join(f"<td{align(c)}>{cell(cells[row])}</td>" for c, cells in zip(table.columns, columns))
                   + "</tr>" for row in range(table.row_count))
    caption = f'<caption style="text-align:left">{cell(table.title)}</caption>' if table.title else ""
    note = f'<p style="text-align:left">{cell(table.caption)}</p>' if table.caption else ""
    return f'<table class="ipyros">{caption}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>{note}'


def render_plain(renderable_: Any) -> str:
    """``renderable_`` as plain text, without colour or width limit (e.g. inside a one-line message)."""
    if is_large(renderable(renderable_)):
        return table_text(rich_cast(renderable(renderable_)))
    buffer = io.StringIO()
    Console(file=buffer, color_system=None, force_jupyter=False, width=10_000).print(renderable(renderable_))
    return buffer.getvalue().rstrip("\n")


def _width(default: int) -> int:
    import shutil

    return max(60, shutil.get_terminal_size((default, 24)).columns)


def versions_table(versions: Versions) -> Table:
    """The versions of one handler, oldest first; (now) marks the live one."""
    return rich_table(versions.table())


def rows_table(rows: Rows) -> Table:
    """Any other record of rows (a bag's topics, ...): the table it says it holds."""
    return rich_table(rows.table())


#: How each record type looks (the most specific class of an object's MRO wins).
RENDERERS: dict[type, Callable[[Any], Any]] = {
    rosNode: node_table, NodeStatus: status_table, History: history_table, Versions: versions_table,
    Interface: interface_table, DemoRobot: robot_table, TrialReport: trial_view, Rows: rows_table,
    BagTrial: lambda trial: rich_table(trial.table()),
}


def renderable(obj: Any) -> Any:
    """What rich prints for ``obj``: its renderer's table if it is a record, else ``obj`` itself."""
    for cls in type(obj).__mro__:
        render = RENDERERS.get(cls)
        if render is not None:
            return render(obj)
    return obj


def register(shell: Any) -> list[tuple[Any, type, Any]]:
    """Have ``shell`` show the records as tables (text in a terminal, HTML in Jupyter) and a drawn graph as itself
    (a tree in a terminal, an SVG in Jupyter); what :func:`unregister` takes to put things back as they were."""
    formatters = shell.display_formatter.formatters
    done = []
    for cls in _with_subclasses(RENDERERS):
        for mime, show in (("text/plain", _pretty), ("text/html", render_html)):
            formatter = formatters[mime]
            done.append((formatter, cls, formatter.for_type(cls, show)))
    for mime, show in (("text/plain", _picture_text), ("image/svg+xml", picture_svg)):
        formatter = formatters[mime]
        done.append((formatter, Picture, formatter.for_type(Picture, show)))
    return done


def _picture_text(drawn: Picture, printer: Any, cycle: bool) -> None:
    printer.text(to_text(drawn, _width(100)))


#: How large a picture is drawn below a cell at most (inches, wide and high): a notebook's output is about 10 inches
#: wide beside JupyterLab's side bar; a larger graph is scaled down to fit, not cut (``--save`` keeps its size).
CELL_FIT = (10.0, 12.0)


def picture_svg(drawn: Picture) -> Optional[str]:
    """The picture laid out by Graphviz, as SVG text, scaled to fit a cell; None without Graphviz (the tree is shown
    instead)."""
    try:
        return layout(to_dot(drawn, CELL_FIT)).decode()
    except IpyrosError:
        return None


def _with_subclasses(classes: Any) -> list[type]:
    """Each class and all its subclasses: IPython's pretty printer takes a subclass's own ``__repr__`` (a dataclass
    has one) before a printer registered for its base, so each record class is registered by name."""
    found: list[type] = []
    todo = list(classes)
    while todo:
        cls = todo.pop(0)
        if cls not in found:
            found.append(cls)
            todo += cls.__subclasses__()
    return found


def unregister(done: list[tuple[Any, type, Any]]) -> None:
    """Undo :func:`register`."""
    for formatter, cls, previous in reversed(done):
        if previous is None:
            formatter.pop(cls, None)
        else:
            formatter.for_type(cls, previous)


def _pretty(obj: Any, printer: Any, cycle: bool) -> None:
    printer.text(repr(obj) if cycle else render_text(obj))
