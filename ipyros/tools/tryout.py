"""Try before swap: run a candidate handler on the messages a live handler just saw, or on a whole bag.

Each subscription of a running node keeps its last messages (``HandlerSlot.recent``).
:func:`try_candidate` feeds each of them to the live handler and to the candidate, one
after the other in the calling thread, and records for each call:

* what it printed (``print``, ``sys.stdout``/``sys.stderr`` writes, rich output);
* what it wrote through ``rosNode.write``, checked as ``write`` would check it (the
  node publishes that topic, the message has its type) but **not published**;
* the exception it raised, and how long it took.

:func:`try_bag` does the same over every message of a recorded bag, in the session's process and
without a ROS graph (the node need not be created; nothing is published): the rehearsal on recorded
data before the robot. It returns a :class:`BagTrial`: how many messages ran, on how many the two
differ, each side's outputs by topic and bag time, and the first differences side by side.

What is *not* isolated, honestly: both handlers really run. Each gets its own deep copy
of the message, and writes are recorded instead of sent, but anything else they do
happens for real: changing globals, setting parameters, publishing through a publisher
of their own.
Only calls made from the trying thread are intercepted (nothing process-wide is swapped:
:mod:`ipyros.core.streams` and :func:`~ipyros.node.writing.writes_recorded` are per thread): the
node's ROS callbacks keep running, printing and publishing as usual meanwhile.
"""

from __future__ import annotations

import contextlib
import gc
import io
import itertools
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator, Optional, Sequence

from ..core import msgpath, msgtypes, plan as planning, streams
from ..core.errors import IpyrosError, NotDeclaredError
from ..core.msgbuild import copy_message, flow_yaml, same_message
from ..core.slots import call_arity
from ..core.records import short_repr
from ..core.tables import Column, TextTable
from ..dsl import engine_of, rosNode
from ..node.engine import NodeEngine
from ..node.writing import writes_recorded
from .record import bag_module
from .rehearsal import RehearsedGuards, said


# Write and Outcome are not frozen: a frozen dataclass's __init__ sets each field through object.__setattr__, 3.5x
# the time of a plain one, and a try over a bag makes four of them a message (nothing changes them once made).
@dataclass(slots=True)
class Write:
    """One ``node.write(topic, message)`` a handler made during the try."""

    node: str
    topic: str
    message: Any
    problem: Optional[str] = None  # why the real write would have failed
    guard: str = ""  # what the topic's guard did with it, in a try over a bag ("": passed as it came, or none)
    reached: Any = None  # what of it would reach the robot then (None: nothing, dropped)

    def __str__(self) -> str:
        if self.problem:
            return f"write {self.topic} would fail: {self.problem}"
        text = f"write {self.topic}: {one_line(self.message)}"
        if self.guard:
            text += f", {self.guard}" + (f": {one_line(self.reached)} reaches the robot" if self.reached is not None
                                         else "")
        return text


@dataclass(slots=True)
class Outcome:
    """What one handler did with one message."""

    printed: str
    writes: tuple[Write, ...]
    error: Optional[str]  # "ZeroDivisionError: division by zero"
    ms: float

    def lines(self) -> list[str]:
        out = self.printed.rstrip("\n").splitlines()
        out += [f"→ {w}" for w in self.writes]
        if self.error:
            out.append(f"! {self.error}")
        return out

    def same_as(self, other: "Outcome") -> bool:
        if self.printed != other.printed or self.error != other.error or len(self.writes) != len(other.writes):
            return False
        for a, b in zip(self.writes, other.writes):  # (a loop: a generator for all() costs as much as a compare)
            if a.topic != b.topic or a.problem != b.problem or not same_message(a.message, b.message):
                return False
        return True


def silent_sides(pairs: Sequence[Any]) -> list[str]:
    """Of "live" and "candidate", the sides that did nothing (printed, wrote and raised nothing) on every one of
    ``pairs`` (rows of a try, differences of a bag trial): said once, not as a column of empty cells."""
    return [side for side in ("live", "candidate") if pairs and not any(getattr(p, side).lines() for p in pairs)]


@dataclass(frozen=True)
class TrialRow:
    index: int  # 1 = the oldest message tried
    message: Any
    live: Outcome
    candidate: Outcome

    @property
    def same(self) -> bool:
        return self.live.same_as(self.candidate)


@dataclass(frozen=True)
class TrialReport:
    """The live handler and the candidate side by side, one row per message."""

    node: str
    topic: str
    live_name: str
    candidate_name: str
    rows: tuple[TrialRow, ...]

    @property
    def differing(self) -> int:
        return sum(not r.same for r in self.rows)


def try_candidate(node: rosNode, topic: str, candidate: Callable[..., Any],
                  last: Optional[int] = None) -> TrialReport:
    """Run the live handler of ``topic`` and ``candidate`` on the node's recent messages.

    ``last`` limits the try to that many of the most recent messages. Nothing is swapped.
    """
    resolved = node.resolve(topic)
    live = node.handler(topic)
    slot = engine_of(node).slot(planning.topic_slot(resolved))
    if live is None or node.model().topic(resolved, "subscribe", "new") is None:
        raise NotDeclaredError(f"{node.name} has no handler for {resolved}; %try compares subscription handlers")
    call_arity(candidate, "subscribe", f"{node.name} {resolved}")
    messages = slot.recent_messages() if slot is not None else []
    if last is not None:
        messages = messages[-last:] if last > 0 else []
    if not messages:
        state = "is not running" if not node.created else "has received no messages yet"
        raise IpyrosError(f"nothing to try on: {node.name} {state} on {resolved}; "
                          "wait for messages, then try again")
    rows = []
    with _intercepted() as run:
        for index, msg in enumerate(messages, 1):
            rows.append(TrialRow(index, msg, run(live, msg), run(candidate, msg)))
    return TrialReport(node.name, resolved, _name(live), _name(candidate), tuple(rows))


@dataclass(frozen=True)
class Difference:
    """One message on which the live handler and the candidate did not do the same."""

    at: float  # bag time of the message, s from the bag's first message
    message: Any
    live: Outcome
    candidate: Outcome


@dataclass(frozen=True, repr=False)
class BagTrial:
    """The live handler and a candidate over a whole bag: what each sent, and where they differ.

    ``outputs[side][topic]`` is the list of ``(bag time in s from the bag's start, message)`` that side wrote
    on ``topic`` (``side``: ``"live"`` or ``"candidate"``), for a plot; ``first`` the first differences.
    """

    node: str
    topic: str
    bag: str
    live_name: str
    candidate_name: str
    total: int
    differing: int
    outputs: dict[str, dict[str, list[tuple[float, Any]]]]
    first: tuple[Difference, ...]
    others: int = 0  # messages of the node's other subscriptions run through their live handlers
    seconds: float = 0.0  # how long the run took
    stopped: bool = False  # Ctrl-C ended it: what ran until then
    #: Per side, per guarded output, how many writes its guard passed as they came, clamped, dropped or stopped.
    guarded: dict[str, dict[str, dict[str, int]]] = field(default_factory=dict)

    def table(self) -> TextTable:
        """Counts per output topic on each side, then the first differences side by side."""
        topics = sorted({t for side in self.outputs.values() for t in side})
        rows: list[tuple[str, ...]] = [(topic, str(len(self.outputs["live"].get(topic, ()))),
                                        str(len(self.outputs["candidate"].get(topic, ())))) for topic in topics]
        for topic in sorted({t for side in self.guarded.values() for t in side}):
            rows.append((f"its guard, {topic}", *(_tally(self.guarded.get(side, {}).get(topic, {}))
                                                  for side in ("live", "candidate"))))
        sections = (len(rows),) if self.first else ()
        for diff in self.first:  # a side that did nothing is an empty cell, said once in the title
            rows.append((f"at {diff.at:.3f} s: {one_line(diff.message, 40)}", "\n".join(diff.live.lines()),
                         "\n".join(diff.candidate.lines())))
        names = {"live": self.live_name, "candidate": self.candidate_name}
        silent = [names[side] for side in silent_sides(self.first)]
        quiet = f"; {' and '.join(silent)} did nothing on the first differences shown" if silent else ""
        others = f" (and {self.others} of its other subscriptions, through their live handlers)" if self.others else ""
        title = (f"{self.candidate_name} against {self.live_name} on {self.total} messages of {self.topic} from "
                 f"{self.bag}{others}: {self.differing} differ ({self.seconds:.2f} s"
                 f"{'; stopped by Ctrl-C, the rest of the bag not tried' if self.stopped else ''}){quiet}")
        return TextTable(title, (Column("output / message", fold=True), Column(self.live_name, fold=True),
                                 Column(self.candidate_name, fold=True)), tuple(rows), sections)

    def __str__(self) -> str:
        return self.table().text()

    def __repr__(self) -> str:
        return short_repr(self, self.table().title)

    def series(self, field: str) -> tuple[str, list[tuple[str, list[float], list[float]]]]:
        """One number field of what each side wrote, over bag time, for a chart: ``(what is drawn, [(side,
        times, values), ...])``. ``field`` is a path into the messages of the output topic (``linear.x``,
        ``poses[0].position.x``), or, when the sides wrote on several, into one of them (``/cmd_vel.linear.x``).
        A one-line error names the topics there are, or what is wrong with the field."""
        topics = sorted({t for side in self.outputs.values() for t in side})
        if not topics:
            raise IpyrosError(f"neither {self.live_name} nor {self.candidate_name} wrote anything: nothing to plot")
        topic = next((t for t in topics if field == t or field.startswith((t + ".", t + "["))), None)
        if topic is None and len(topics) > 1:
            raise IpyrosError(f"--plot {field}: the handlers wrote on {', '.join(topics)}: name the topic too, "
                              f"e.g. --plot {topics[0]}.{field.lstrip('.')}")
        topic = topic or topics[0]
        rest = field[len(topic):] if field.startswith(topic) else field
        path = msgpath.parse(topic + (rest if not rest or rest.startswith(("[", "{")) else "." + rest.lstrip(".")))
        drawn = []
        for side, name in (("live", self.live_name), ("candidate", self.candidate_name)):
            times, values = [], []
            for at, msg in self.outputs[side].get(topic, ()):
                found = path.values(msg)
                if not found:
                    continue  # a filter left nothing in this message
                if isinstance(found[0], bool) or not isinstance(found[0], (int, float)):
                    raise IpyrosError(f"--plot {path.text}: a {type(found[0]).__name__}, not a number: plot a "
                                      "number field")
                times.append(at)
                values.append(float(found[0]))
            drawn.append((f"{name} ({side})", times, values))
        return path.text, drawn


def try_bag(node: rosNode, topic: str, candidate: Callable[..., Any], bag: Any, shown: int = 5) -> BagTrial:
    """Run every message of ``topic`` in the bag ``bag`` through the live handler and ``candidate``, side by side.

    The node's other subscriptions get their messages from the bag too, in recorded order, through their
    live handlers (what they change, both sides see; what they write is not counted). Nothing is published
    and the node need not be created: no master or robot is needed, only the bag and the handlers.
    """
    resolved = node.resolve(topic)
    live = node.handler(topic)
    if live is None or node.model().topic(resolved, "subscribe", "new") is None:
        raise NotDeclaredError(f"{node.name} has no handler for {resolved}; %try compares subscription handlers")
    call_arity(candidate, "subscribe", f"{node.name} {resolved}")
    path = Path(bag).expanduser()
    if not path.exists():
        raise IpyrosError(f"no bag at {path}: give a bag file or a rosbag2 folder (%record writes one)")
    handlers = {t.resolved: node.handler(t.resolved) for t in node.model().topics
                if t.direction == "subscribe" and t.role == "new" and t.resolved != resolved}
    handlers = {t: h for t, h in handlers.items() if h is not None}
    outputs: dict[str, dict[str, list[tuple[float, Any]]]] = {"live": {}, "candidate": {}}
    first: list[Difference] = []
    total = differing = others = 0
    start: Optional[int] = None
    began = time.perf_counter()
    stopped = False
    guards = RehearsedGuards(node.model().guards) if node.model().guards else None
    inputs = guards.inputs if guards is not None else set()
    counts: list[int] = []  # how many messages there are, heard as the bag opens (for the progress's time left)
    messages = bag_module().bag_messages(path, {resolved, *handlers, *inputs}, counts.append)
    live_out, candidate_out = outputs["live"], outputs["candidate"]
    seen = 0
    with _intercepted() as run, contextlib.closing(messages), _young_collections_only() as tick, \
            contextlib.ExitStack() as showing:
        try:  # (the bag's reader is closed at once, even on Ctrl-C)
            opening = next(messages, None)  # opens the bag (its index read with the collector off: a tenth faster)
            step = showing.enter_context(engine_of(node).session.progress(
                f"%try {resolved} over {path.name}", counts[0] if counts else None, "messages"))
            for name, stamp, msg in itertools.chain((opening,) if opening is not None else (), messages):
                tick()
                seen += 1
                if not seen & 1023:  # a view redraws a few times a second: told every 1,024 messages
                    step(seen)
                if start is None:
                    start = stamp
                at = (stamp - start) / 1e9
                if guards is not None:
                    guards.now = at
                    if name in inputs:  # what the guards' rules read, as the robot sensed it then
                        guards.heard_at(name, msg, at)
                if name != resolved:
                    if name in handlers:
                        run(handlers[name], msg)
                        others += 1
                    continue
                done, tried = run(live, msg), run(candidate, msg)
                total += 1  # counted once both sides ran: a message Ctrl-C cut in half is not half-counted
                if guards is not None:
                    _guard(guards, "live", done)
                    _guard(guards, "candidate", tried)
                for out, made in ((live_out, done.writes), (candidate_out, tried.writes)):
                    for write in made:
                        series = out.get(write.topic)
                        if series is None:
                            series = out[write.topic] = []
                        series.append((at, write.message))
                if not done.same_as(tried):
                    differing += 1
                    if len(first) < shown:
                        first.append(Difference(at, msg, done, tried))
        except KeyboardInterrupt:
            stopped = True  # what ran until now is the answer
    if stopped and total == 0:
        raise IpyrosError(f"%try stopped by Ctrl-C before any message of {resolved} was tried")
    if total == 0:
        raise IpyrosError(f"the bag {path} holds no message of {resolved}; %bag info {path} lists what it holds")
    return BagTrial(node.name, resolved, str(path), _name(live), _name(candidate), total, differing, outputs,
                    tuple(first), others, time.perf_counter() - began, stopped,
                    guards.counts if guards is not None else {})


def _guard(guards: RehearsedGuards, side: str, outcome: Outcome) -> None:
    """Each write of ``outcome`` on a guarded output through that side's gate: what the guard did, what reaches."""
    for write in outcome.writes:
        verdict = guards.judge(side, write.topic, write.message)
        if verdict is not None:
            write.guard, write.reached = said(verdict), verdict.send


def _tally(counts: dict[str, int]) -> str:
    """``45 passed, 5 clamped``: a guard's verdicts on one side's writes."""
    return ", ".join(f"{n} {acting}" for acting, n in sorted(counts.items(), key=lambda kv: -kv[1])) or "-"


#: The writes of one call kept by a try: a handler that writes more for one input is said to, and the rest only counted.
WRITES_KEPT = 1000

#: Messages between two collections of the young objects while a try runs over a bag.
YOUNG_EVERY = 10000


@contextlib.contextmanager
def _young_collections_only() -> Iterator[Callable[[], None]]:
    """Within the block, Python's automatic garbage collection is off, and ``tick()`` (once a message) collects the
    young objects every :data:`YOUNG_EVERY` calls. A try keeps every output of both sides: the collector's full
    walks over them took half a try's time (100,000 messages: 28,770 msg/s, 57,419 without). Cycles the handlers
    make are still freed by the young collections; what lives longer waits for the collector's return."""
    was_on = gc.isenabled()
    count = 0

    def tick() -> None:
        nonlocal count
        count += 1
        if count % YOUNG_EVERY == 0:
            gc.collect(1)

    gc.disable()
    try:
        yield tick
    finally:
        if was_on:
            gc.enable()


# -- capturing one thread's prints and writes -----------------------------------------------


def _write_problem(node: NodeEngine, topic: str, msg: Any) -> Optional[str]:
    """What ``node.write(topic, msg)`` would raise, in words; None if it would publish."""
    try:
        resolved = node.resolve(topic)
    except IpyrosError as error:
        return str(error)
    model = node.model()
    if planning.write_target(model, resolved) is None:
        return f"{node.name} does not publish {resolved}"
    declared = next(t.type for t in model.topics if t.resolved == resolved)
    got = msgtypes.type_name(msg) or type(msg).__name__  # pkg/Type on both ROS (ROS 2 classes have no _type)
    return None if got == declared else f"{resolved} carries {declared}, not {got}"


@contextlib.contextmanager
def _intercepted() -> Iterator[Callable[[Callable[..., Any], Any], Outcome]]:
    """Within the block, ``run(handler, msg)`` calls the handler with what it prints and writes kept, in this thread
    alone: its prints go to a sink of this thread (:mod:`ipyros.core.streams`), its writes to a recorder of this
    thread's context (:func:`~ipyros.node.writing.writes_recorded`); other threads print and publish as usual."""
    buffer = io.StringIO()  # this thread's prints, for the whole try: read and emptied after each call
    writes: list[Write] = []  # the writes of the calls in progress, the innermost call's last
    # A write's problem depends only on the node, the topic and the message's type, which a try does not change:
    # checked once (with the node's name), not for each of a bag's messages.
    checked: dict[tuple[int, str, type], tuple[str, Optional[str]]] = {}
    clock = time.perf_counter
    begun = 0  # where the call in progress starts in writes
    unkept = 0  # how many of its writes were not kept

    def record(node: NodeEngine, topic: str, msg: Any) -> None:
        nonlocal unkept
        if len(writes) - begun >= WRITES_KEPT:  # a runaway handler: counted, not kept (memory stays bounded)
            unkept += 1
            return
        key = (id(node), topic, type(msg))
        found = checked.get(key)
        if found is None:
            found = checked[key] = (node.name, _write_problem(node, topic, msg))
        writes.append(Write(found[0], topic, copy_message(msg), found[1]))

    def run(handler: Callable[..., Any], msg: Any) -> Outcome:
        nonlocal begun, unkept
        outer = begun, unkept  # (a call within a call: the outer one's, back after it)
        mark = begun = len(writes)
        unkept = 0
        error = None
        start = clock()
        try:
            handler(copy_message(msg))
        except (Exception, SystemExit) as exc:  # shown in the table: what the handler would do live (its slot catches
            # a SystemExit too); Ctrl-C is the person's, and stops the try
            error = "".join(traceback.format_exception_only(type(exc), exc)).strip()
        finally:
            elapsed = (clock() - start) * 1e3
            made = tuple(writes[mark:])
            del writes[mark:]
            if unkept:
                error = (f"{error}; " if error else "") + (f"wrote {WRITES_KEPT + unkept:,} messages for one input: "
                                                           f"the first {WRITES_KEPT:,} kept")
            begun, unkept = outer
        printed = ""
        if buffer.tell():
            printed = buffer.getvalue()
            buffer.seek(0)
            buffer.truncate()
        return Outcome(printed, made, error, elapsed)

    streams.route()  # once (the extension does it as it loads): a no-op after
    with writes_recorded(record), streams.into(buffer):
        yield run


def one_line(msg: Any, width: int = 80) -> str:
    """A message as one short line of YAML (the same on both ROS: ``{linear: {x: 1.0, ...}, ...}``)."""
    try:
        text = " ".join(flow_yaml(msg).removesuffix("\n...\n").split())  # a plain value's YAML ends its document
    except Exception:  # noqa: BLE001 - not a message: its text
        text = " ".join(str(msg).split())
    return text if len(text) <= width else text[: width - 1] + "…"


def _name(fn: Any) -> str:
    return getattr(fn, "__name__", type(fn).__name__)


__all__ = ["BagTrial", "Difference", "try_bag", "try_candidate", "TrialReport", "TrialRow", "Outcome", "Write",
           "silent_sides"]
