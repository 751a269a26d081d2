"""A node's guards as a rehearsal on a bag runs them: what of a handler's writes would reach the robot.

``%try NODE TOPIC CANDIDATE --bag FILE`` runs both handlers on recorded messages; a write on a guarded output
then passes that guard's gate (:class:`ipyros.core.guard.Gate`, the very check the session runs), on the bag's
own time, its rules fed with the bag's own messages of their inputs (a laser, a bumper). Each side has gates of
its own (a rate limit, a rule's ``hold`` and the last command are a side's). What is rehearsed, and what not:
each write is judged as it is made; a stop that a running guard sends with no command coming (an input gone
stale between two commands, the stop on silence) is not a write, and is not shown.
"""

from __future__ import annotations

from typing import Any, Optional

from ..core import msgtypes
from ..core.errors import IpyrosError, MessageTypeError
from ..core.guard import Acting, Gate, Verdict
from ..core.model import GuardModel
from ..core.msgbuild import build_message, copy_message
from ..core.rules import RuleSet, as_rule
from ..node.liveguard import limits_of

__all__ = ["RehearsedGuards", "said"]


class RehearsedGuards:
    """The guards of a node's model, one set of gates a side (``live``, ``candidate``), on bag time (``now``, s)."""

    def __init__(self, guards: list[GuardModel], sides: tuple[str, ...] = ("live", "candidate")) -> None:
        self.now = 0.0
        self.heard: dict[str, tuple[Any, float]] = {}
        self.gates = {side: {g.resolved: self._gate(g) for g in guards} for side in sides}
        self.inputs = {topic for gates in self.gates.values() for gate in gates.values() for topic in gate.inputs}
        #: Per side, per guarded topic, how many writes the gate passed as they came, clamped, dropped or stopped.
        self.counts: dict[str, dict[str, dict[str, int]]] = {side: {} for side in sides}

    def _gate(self, model: GuardModel) -> "_RehearsedGate":
        where = f"guard {model.resolved}"
        try:
            cls = msgtypes.resolve_message(model.type)[1]
        except MessageTypeError:
            raise IpyrosError(f"{where}: a rehearsal runs the node's guards, and {model.type} is not installed "
                              "here") from None
        stop = build_message(cls, model.stop) if model.stop is not None else cls()
        rules = (RuleSet([as_rule(r, where) for r in model.rules], cls, model.resolved, model.stale, where)
                 if model.rules or model.stale else None)
        gate = Gate(model.resolved, cls, limits_of(model), dict(model.rate), model.on_limit,
                    lambda: copy_message(stop), lambda: False, lambda: None, lambda text: None,
                    clock=lambda: self.now, rules=rules, heard=lambda: self.heard)
        return _RehearsedGate(gate, rules.topics if rules is not None else ())

    def heard_at(self, topic: str, msg: Any, at: float) -> None:
        """A message of one of the rules' inputs, as the bag holds it at bag time ``at``."""
        self.heard[topic] = (msg, at)

    def judge(self, side: str, topic: str, msg: Any) -> Optional[Verdict]:
        """What the guard of ``topic`` does with ``msg`` written by ``side`` (None: the topic is not guarded)."""
        found = self.gates[side].get(topic)
        if found is None:
            return None
        verdict = found.gate.check(msg)
        tally = self.counts[side].setdefault(topic, {})
        acting = "dropped" if verdict.send is None else verdict.acting.value
        tally[acting] = tally.get(acting, 0) + 1
        return verdict


class _RehearsedGate:
    def __init__(self, gate: Gate, inputs: tuple[str, ...]) -> None:
        self.gate, self.inputs = gate, inputs


def said(verdict: Verdict) -> str:
    """A verdict as a write shows it: "" when it passed as it came."""
    if verdict.acting is Acting.PASSED:
        return ""
    if verdict.send is None:
        return "dropped by its guard (outside its limits)"
    return f"{verdict.acting.value} by its guard" + (f": {verdict.why}" if verdict.why not in ("", verdict.acting.value)
                                                     else "")
