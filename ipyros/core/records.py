"""What ipyros reports, as plain records: a node's status, history and handler versions, a node's interface.

Records are data: the DSL and the tools return them, tests read their fields, files save
them. Each also says what its table holds (``table()``, a :class:`~ipyros.core.tables.TextTable`),
so that ``print(nd.status())`` in a script or a handler shows the table as text; how it looks
at the prompt (rich in a terminal, an HTML table in Jupyter) is the IPython face's business
(:mod:`ipyros.ipython.display`), which draws the same table.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Any, Iterator, Optional, Union

from .tables import Cell, Column, TextTable

__all__ = ["BagInfo", "BagTopic", "History", "Interface", "Machine", "Machines", "NodeStatus", "Rows", "StatusRow",
           "Versions", "short_repr"]


class Rows:
    """A sequence of records (``rows``): ``len``, iteration and indexing go to the rows; ``str()`` is its table."""

    rows: tuple[Any, ...]

    def __len__(self) -> int:
        return len(self.rows)

    def __iter__(self) -> Iterator[Any]:
        return iter(self.rows)

    def __getitem__(self, index: int) -> Any:
        return self.rows[index]

    def table(self) -> TextTable:
        raise NotImplementedError

    def __str__(self) -> str:
        return self.table().text()

    def __repr__(self) -> str:
        """Short, and naming what it is: its table's title (the table itself is ``str()``, or the prompt's view)."""
        return short_repr(self, self.table().title)


def short_repr(record: Any, summary: str, limit: int = 100) -> str:
    """``<Kind: summary>`` on one line, cut to about ``limit`` characters: a record's repr at the prompt."""
    summary = " ".join(summary.split())
    if len(summary) > limit:
        summary = summary[: limit - 1] + "…"
    return f"<{type(record).__name__}: {summary}>"


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


@dataclass(frozen=True, repr=False)
class NodeStatus(Rows):
    """Per handler and per topic sent on: calls, rate, handler time, exceptions, drops."""

    node: str
    running: bool
    rows: tuple[StatusRow, ...]
    params: tuple[tuple[str, str], ...] = ()  # the node's own parameters as they are now (set from outside too)
    guards: tuple[Any, ...] = ()  # its guards (ipyros.core.guard.GuardState): state, what each did

    def row(self, name: str) -> StatusRow:
        return next(r for r in self.rows if r.name == name)

    def table(self) -> TextTable:
        """One row per handler and per topic sent on; the node's parameters under them."""
        columns = (Column("kind"), Column("name"), Column("handler"), Column("calls", True), Column("rate Hz", True),
                   Column("mean ms", True), Column("max ms", True), Column("errors", True),
                   Column("subscribers", True), Column("dropped", True))
        rows: list[tuple[Union[str, Cell], ...]] = []
        for r in self.rows:
            errors: Union[str, Cell] = Cell(str(r.errors), "red") if r.errors else "0"
            if r.handler:
                rest: tuple[Union[str, Cell], ...] = (f"{r.rate_hz:.1f}", f"{r.mean_ms:.3f}", f"{r.max_ms:.3f}", errors,
                                                      "", "")
            else:  # a topic sent on: who gets it, and what slow subscribers lost
                waiting = f" ({r.waiting} waiting)" if r.waiting else ""
                rest = ("", "", "", "", str(r.connections),
                        Cell(f"{r.dropped}{waiting}", "red") if r.dropped else f"0{waiting}")
            rows.append((r.kind, r.name, r.handler, str(r.calls), *rest))
        rows += [("param", name, value, *[""] * 7) for name, value in self.params]
        for guard in self.guards:
            f = guard.figures
            did = f"{guard.state}; {f.clamped} clamped, {f.dropped} dropped, {f.replaced} stopped in place, " \
                  f"{guard.stops_sent} stops sent by its process" + (f"; last: {f.last_trip} at " +
                                                                  time.strftime("%H:%M:%S",
                                                                                time.localtime(f.last_trip_at))
                                                                  if f.last_trip else "")
            state: Union[str, Cell] = Cell(did, "bold red") if guard.state != "passing" else did
            # subscribers: those its process reaches, where a stop message on silence goes
            rows.append(("guard", guard.topic, state, str(f.passed), *[""] * 4, str(guard.reach), ""))
            rows += [("rule", guard.topic, text, *[""] * 7) for text in getattr(guard, "rules", ())]
        title = f"status of {self.node}" + ("" if self.running else " (not running)")
        return TextTable(title, columns, tuple(rows))


@dataclass(frozen=True, repr=False)
class History(Rows):
    """A node's changes, oldest first (:class:`ipyros.core.journal.Change`)."""

    node: str
    rows: tuple[Any, ...]
    path: Any = None  # the file the session writes its history to, if any

    def table(self) -> TextTable:
        kept = f" (kept in {self.path})" if self.path else ""
        return TextTable(f"history of {self.node}{kept}", (Column("#", True), Column("time"), Column("change", fold=True)),
                         tuple((str(number), time.strftime("%H:%M:%S", time.localtime(change.time)),
                                change.change + (f" (by {change.by})" if getattr(change, "by", None) else ""))
                               for number, change in enumerate(self.rows, 1)))


@dataclass(frozen=True, repr=False)
class Versions(Rows):
    """The versions of one handler (:class:`ipyros.core.versions.HandlerVersion`), oldest first."""

    label: str  # e.g. "kobuki /cmd_vel"
    rows: tuple[Any, ...]
    current: Optional[int]  # the number of the version serving now, or None

    def table(self) -> TextTable:
        """Oldest first; ``(now)`` marks the version serving; each with the first line of its body."""
        rows: list[tuple[Union[str, Cell], ...]] = []
        for v in self.rows:
            lines = [line.strip() for line in (v.source or "").splitlines() if line.strip()]
            body = next((line for line in lines[1:] if not line.startswith(("#", '"""', "'''"))),
                        lines[0] if lines else "no source")
            rows.append((f"{v.number}{' (now)' if v.number == self.current else ''}", v.when, v.name, str(len(lines)),
                         body))
        if not rows:
            rows.append(("", "", "no versions yet", "", ""))
        columns = (Column("#", True, True), Column("time", fold=True), Column("handler", fold=True),
                   Column("lines", True, True), Column("first line of its body", fold=True))
        return TextTable(f"versions of the handler of {self.label}", columns, tuple(rows))


@dataclass(frozen=True)
class BagTopic:
    """One topic of a bag: its name, type and how many messages it holds."""

    topic: str
    type: str
    count: int


@dataclass(frozen=True, repr=False)
class BagInfo(Rows):
    """What a bag holds, as ``rosbag info`` / ``ros2 bag info`` say it: its topics, start, end and length.

    ``start`` and ``end`` are the first and last message's time (s since the epoch; 0 for an empty
    bag); ``storage`` says what the file is (``bag`` for ROS 1, ``mcap`` or ``sqlite3`` for rosbag2).
    """

    path: str
    storage: str
    start: float
    end: float
    rows: tuple[BagTopic, ...]

    @property
    def duration(self) -> float:
        return self.end - self.start

    @property
    def messages(self) -> int:
        return sum(row.count for row in self.rows)

    def table(self) -> TextTable:
        """A row per topic; the title says the storage, the message count, start, end and duration."""
        span = "" if not self.messages else (
            f", {time.strftime('%Y-%m-%d %H:%M:%S', time.localtime(self.start))} to "
            f"{time.strftime('%H:%M:%S', time.localtime(self.end))} ({self.duration:.3f} s)")
        title = f"bag {self.path} ({self.storage}): {self.messages} messages{span}"
        rows = tuple((row.topic, row.type, str(row.count)) for row in self.rows)
        return TextTable(title, (Column("topic"), Column("type"), Column("messages", True)), rows)


@dataclass(repr=False)
class Interface:
    """The publish/subscribe/service interface of one running node, as plain data.

    Each entry is ``(global name, type)``; a type is ``""`` when it is not known: a
    topic subscribed to as "any type" (rospy.AnyMsg, topic_tools' ShapeShifter: the
    master records no type for those) that nobody publishes yet, or a service that did
    not answer the probe. ``left_out`` names the ROS plumbing that was seen but is not
    part of the interface (e.g. ``"/rosout (publishes)"``); ``not_seen`` the names
    declared for it that it did not use while it was watched (some nodes advertise only
    after their first input); ``not_installed`` the ``name (type)`` of those whose types this
    Python cannot import, which ``discover()`` left undeclared.
    """

    node: str
    publications: list[tuple[str, str]] = field(default_factory=list)
    subscriptions: list[tuple[str, str]] = field(default_factory=list)
    services: list[tuple[str, str]] = field(default_factory=list)
    left_out: list[str] = field(default_factory=list)
    not_seen: list[str] = field(default_factory=list)
    actions: list[tuple[str, str]] = field(default_factory=list)  # the action servers, found by fold_actions()
    not_installed: list[str] = field(default_factory=list)

    def fold_actions(self) -> "Interface":
        """This interface with the actions the node serves taken out of its topics and services, into
        ``actions`` (``pkg/Type``); the interface itself is left as it was.

        An action is a set of topics (ROS 1: ``NAME/goal`` of a ``pkg/TypeActionGoal`` and
        four more; ROS 2: ``NAME/_action/feedback`` of a ``pkg/Type_FeedbackMessage``, the
        status topic and three services): a wrapper relays it as one unit, so it is one entry.
        """
        found = {}
        for name, type_name in self.publications:  # ROS 2: the server publishes the feedback
            if name.endswith("/_action/feedback") and type_name.endswith("_FeedbackMessage"):
                package, stem = type_name.split("/")[0], type_name.split("/")[-1]
                found[name.removesuffix("/_action/feedback")] = f"{package}/{stem.removesuffix('_FeedbackMessage')}"
        for name, type_name in self.subscriptions:  # ROS 1: the server subscribes to the goals
            if name.endswith("/goal") and type_name.endswith("ActionGoal"):
                found[name.removesuffix("/goal")] = type_name.removesuffix("ActionGoal")

        def part(entry: tuple[str, str]) -> bool:
            head, _, tail = entry[0].rpartition("/")
            return head.removesuffix("/_action") in found and (head.endswith("/_action") or tail in _ROS1_PARTS)

        return replace(self, publications=[e for e in self.publications if not part(e)],
                       subscriptions=[e for e in self.subscriptions if not part(e)],
                       services=[e for e in self.services if not part(e)], actions=sorted(found.items()))

    def __repr__(self) -> str:
        return short_repr(self, f"{self.node}: {len(self.publications)} published, {len(self.subscriptions)} "
                                f"subscribed, {len(self.services)} services, {len(self.actions)} actions")

    def table(self) -> TextTable:
        """A row per topic, service or action with its direction and type; what was not seen, and the plumbing
        left out, in sections of their own."""
        rows: list[tuple[Union[str, Cell], ...]] = [
            (Cell(label, "bold"), Cell(name, "cyan"), Cell(type_, "green") if type_ else Cell("unknown", "dim"))
            for label, entries in (("publishes", self.publications), ("subscribes", self.subscriptions),
                                   ("service", self.services), ("action", self.actions))
            for name, type_ in entries]
        if not rows:
            rows.append(("", Cell("no topics or services", "dim"), ""))
        sections = []
        if self.not_seen:
            sections.append(len(rows))
            rows.append((Cell("not seen", "yellow"), ", ".join(self.not_seen),
                         Cell("declared; may come after its first input", "dim")))
        if self.left_out:
            short = (entry.split(" ")[0].replace(self.node + "/", "~", 1) for entry in self.left_out)
            sections.append(len(rows))
            rows.append((Cell("not shown", "dim"), Cell(", ".join(short), "dim"), Cell("ROS plumbing", "dim")))
        return TextTable(f"Interface of {self.node}", (Column(""), Column("name"), Column("type")), tuple(rows),
                         tuple(sections))

    def __str__(self) -> str:
        return self.table().text()


#: The topics of a ROS 1 action under its name (actionlib's).
_ROS1_PARTS = ("goal", "cancel", "status", "feedback", "result")


@dataclass(frozen=True)
class Machine:
    """A keeper the session sees (``python -m ipyros.machine`` on a robot's computer): its name, where it runs, what
    it allows to start (package: executables), what sessions placed on it, the link's round trip (median of a few
    pings, ms; None when it did not answer), and whether this session holds its token (it can place on it)."""

    name: str
    host: str = ""
    ros: str = ""
    address: str = ""
    pid: int = 0
    allows: dict[str, list[str]] = field(default_factory=dict)
    guards: tuple[str, ...] = ()
    bases: tuple[str, ...] = ()
    rtt_ms: Optional[float] = None
    token: bool = False
    heard: bool = True  # its info was read (a keeper whose topics linger after it died is not)


@dataclass(frozen=True, repr=False)
class Machines(Rows):
    """The keepers on the graph (:class:`Machine`), as ``%machines`` shows them."""

    rows: tuple[Machine, ...]

    def table(self) -> TextTable:
        columns = (Column("machine"), Column("host"), Column("ROS"), Column("allows", fold=True),
                   Column("guards", fold=True), Column("basenodes", fold=True), Column("round trip ms", True),
                   Column("token here"))
        rows: list[tuple[Union[str, Cell], ...]] = []
        for m in self.rows:
            if not m.heard:
                rows.append((m.name, Cell("no answer: its keeper ended?", "red"), "", "", "", "", "", ""))
                continue
            allows = ", ".join(m.allows) or "guards only"
            rtt: Union[str, Cell] = f"{m.rtt_ms:.1f}" if m.rtt_ms is not None else Cell("no answer", "red")
            token: Union[str, Cell] = "yes" if m.token else Cell("no: copy it to place on it", "yellow")
            rows.append((m.name, m.host, m.ros, allows, ", ".join(m.guards), ", ".join(m.bases), rtt, token))
        title = f"{len(self.rows)} machine{'s' if len(self.rows) != 1 else ''}" if self.rows else \
            "no machine's keeper on this ROS graph (start one on the robot: python -m ipyros.machine --name robot1)"
        return TextTable(title, columns, tuple(rows))

