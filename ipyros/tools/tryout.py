"""Try before swap: run a candidate handler on the messages a live handler just saw.

Each subscription of a running node keeps its last messages (``HandlerSlot.recent``).
:func:`try_candidate` feeds each of them to the live handler and to the candidate, one
after the other in the calling thread, and records for each call:

* what it printed (``print``, ``sys.stdout``/``sys.stderr`` writes, rich output);
* what it wrote through ``rosNode.write``, checked as ``write`` would check it (the
  node publishes that topic, the message has its type) but **not published**;
* the exception it raised, and how long it took.

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
import copy
import io
import time
import traceback
from dataclasses import dataclass
from typing import Any, Callable, Iterator, Optional

from ..core import msgtypes, plan as planning, streams
from ..core.errors import IpyrosError, NotDeclaredError
from ..core.msgbuild import flow_yaml
from ..core.slots import call_arity
from ..dsl import engine_of, rosNode
from ..node.engine import NodeEngine
from ..node.writing import writes_recorded


@dataclass(frozen=True)
class Write:
    """One ``node.write(topic, message)`` a handler made during the try."""

    node: str
    topic: str
    message: Any
    problem: Optional[str] = None  # why the real write would have failed

    def __str__(self) -> str:
        if self.problem:
            return f"write {self.topic} would fail: {self.problem}"
        return f"write {self.topic}: {one_line(self.message)}"


@dataclass(frozen=True)
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
        return (self.printed, self.error, [(w.topic, w.message, w.problem) for w in self.writes]) == \
            (other.printed, other.error, [(w.topic, w.message, w.problem) for w in other.writes])


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


# -- capturing one thread's prints and writes -----------------------------------------------


class _Recorder:
    """The writes of one handler call."""

    def __init__(self) -> None:
        self.writes: list[Write] = []

    def record(self, node: NodeEngine, topic: str, msg: Any) -> None:
        self.writes.append(Write(node.name, topic, copy.deepcopy(msg), _write_problem(node, topic, msg)))


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
    buffer = io.StringIO()
    recorder: list[_Recorder] = []  # the recorder of the call in progress, if any

    def record(node: NodeEngine, topic: str, msg: Any) -> None:
        recorder[-1].record(node, topic, msg)

    def run(handler: Callable[..., Any], msg: Any) -> Outcome:
        buffer.seek(0)
        buffer.truncate()
        recorder.append(_Recorder())
        error = None
        start = time.perf_counter()
        try:
            with streams.into(buffer):
                handler(copy.deepcopy(msg))
        except Exception as exc:  # shown in the table: it is what the handler would do live
            error = "".join(traceback.format_exception_only(type(exc), exc)).strip()
        finally:
            elapsed = (time.perf_counter() - start) * 1e3
            writes = tuple(recorder.pop().writes)
        return Outcome(buffer.getvalue(), writes, error, elapsed)

    streams.route()  # once (the extension does it as it loads): a no-op after
    with writes_recorded(record):
        yield run


def one_line(msg: Any, width: int = 80) -> str:
    """A message as one short line of YAML (the same on both ROS: ``{linear: {x: 1.0, ...}, ...}``)."""
    try:
        text = flow_yaml(msg)
    except Exception:  # noqa: BLE001 - not a message: its text
        text = " ".join(str(msg).split())
    return text if len(text) <= width else text[: width - 1] + "…"


def _name(fn: Any) -> str:
    return getattr(fn, "__name__", type(fn).__name__)


__all__ = ["try_candidate", "TrialReport", "TrialRow", "Outcome", "Write"]
