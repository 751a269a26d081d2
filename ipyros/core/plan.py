"""From a node model to the endpoints that must run, and the internal names of wrapped topics.

This is where the wrapping semantics live (the paper's figure 1; docs/architecture.md,
"Wrapping names"), as a pure function of the model: the runtime only opens what the plan lists and closes
what it no longer lists. For a wrapping node W around basenode B, every base topic W
declares gets an *internal* name ``/W/base/<topic>`` and B is launched remapped onto
it, so B talks only to W there:

==============================  ==========================================================
declared                        runs
==============================  ==========================================================
reuse.publish(T)                relay internal(T) → T (bytes, not deserialised)
reuse.publish(T) + new.subscribe(T, h)   h gets B's messages; W publishes T, on which ``write(T)`` sends
reuse.subscribe(T)              relay T → internal(T)
baseNode(...).machine(M)        the relays (topics, services, actions) run on machine M's keeper, beside B
                                (a relay onto a topic guarded here, or on another machine, runs here,
                                behind the gate)
reuse.subscribe(T) + new.subscribe(T, h) h gets T's messages; ``write(T)`` feeds B
new.publish(X) / new.subscribe(X, h)     plain publisher / subscriber on X
reuse.service(S)                W serves S by calling B's internal(S)
reuse.service(S) + new.service(S, h)     h serves S; B's S stays reachable at internal(S)
reuse.action(A)                 goals, cancels, feedback, status and results relayed between
                                A and B's internal(A), as one unit (the backend knows the parts)
new.action(A, h)                h serves A's goals
reuse.action(A) + new.action(A, h)       h serves A's goals and may forward them to B's internal(A)
guard(T)                        a guard on the output T: opened first, every message to T passes it
==============================  ==========================================================
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Union

from . import names
from .model import NodeModel
from .qos import Qos, from_model as qos_of


@dataclass(frozen=True)
class PublishSpec:
    topic: str
    type: str
    latch: bool = False
    qos: Qos = Qos()
    #: The basenode's topic whose latching this one takes (an intercepted output: a latched map stays latched).
    follows: Optional[str] = None


@dataclass(frozen=True)
class SubscribeSpec:
    topic: str
    type: str
    slot: str  # key of the handler slot that serves it
    qos: Qos = Qos()


@dataclass(frozen=True)
class RelaySpec:
    source: str
    target: str
    type: str
    #: The machine whose keeper runs it (a basenode placed there: its topics cross the link once, or not at all);
    #: None: this session runs it.
    machine: Optional[str] = None


@dataclass(frozen=True)
class TimerSpec:
    name: str
    period: float
    oneshot: bool
    slot: str


@dataclass(frozen=True)
class ServiceSpec:
    name: str
    type: str
    slot: str


@dataclass(frozen=True)
class ServiceRelaySpec:
    source: str
    target: str
    type: str
    machine: Optional[str] = None  # as a RelaySpec's


@dataclass(frozen=True)
class ActionServerSpec:
    name: str
    type: str
    slot: str
    forward: Optional[str] = None  # the basenode's own server (internal name), when the action is intercepted


@dataclass(frozen=True)
class ActionRelaySpec:
    source: str
    target: str
    type: str
    machine: Optional[str] = None  # as a RelaySpec's


@dataclass(frozen=True)
class GuardSpec:
    """A guard on the output ``topic`` (its rules are the node's to swap live: see ipyros.node.guards)."""

    topic: str
    type: str


Spec = Union[PublishSpec, SubscribeSpec, RelaySpec, TimerSpec, ServiceSpec, ServiceRelaySpec, ActionServerSpec,
             ActionRelaySpec, GuardSpec]


def topic_slot(resolved: str) -> str:
    return f"topic {resolved}"


def timer_slot(name: str) -> str:
    return f"timer {name}"


def service_slot(resolved: str) -> str:
    return f"service {resolved}"


def action_slot(resolved: str) -> str:
    return f"action {resolved}"


def node_fullname(model: NodeModel) -> str:
    return names.join(names.global_ns(model.namespace), model.name)


def internal_name(model: NodeModel, resolved: str) -> str:
    """Where the basenode is remapped to for base topic/service ``resolved``."""
    return node_fullname(model) + "/base" + resolved


def plan(model: NodeModel) -> dict[Spec, None]:
    """The endpoints the node needs now, in a stable order (a dict used as an ordered set): its guards first, so
    that an output never sends a message before its guard stands (and closes before it, in reverse)."""
    specs: dict[Spec, None] = {}
    outputs = {t.resolved for t in model.topics if t.direction == "publish"}
    for guard in model.guards:
        if guard.resolved in outputs:
            specs[GuardSpec(guard.resolved, guard.type)] = None
    reused_out = {t.resolved for t in model.topics if t.role == "reuse" and t.direction == "publish"}
    reused_in = {t.resolved for t in model.topics if t.role == "reuse" and t.direction == "subscribe"}
    intercepted = {t.resolved for t in model.topics if t.role == "new" and t.direction == "subscribe"}
    placed = model.base.machine if model.base is not None else None

    def run_at(target: str) -> Optional[str]:
        """Where the relay onto ``target`` runs: beside its placed basenode, unless a guard of this session's
        stands on ``target`` (its gate is where the relay's messages must pass: the relay runs here)."""
        guard = model.guard(target)
        return placed if guard is None or guard.machine == placed else None

    for t in model.topics:
        if t.role == "new" and t.direction == "publish":
            specs[PublishSpec(t.resolved, t.type, t.latch, qos_of(t.qos))] = None
        elif t.role == "new":  # subscribe
            source = internal_name(model, t.resolved) if t.resolved in reused_out else t.resolved
            specs[SubscribeSpec(source, t.type, topic_slot(t.resolved), qos_of(t.qos))] = None
            if t.resolved in reused_in:  # the handler replaces the relay; write(T) feeds B
                specs[PublishSpec(internal_name(model, t.resolved), t.type)] = None
        elif t.direction == "publish":  # reuse: B's output out to the world, unless intercepted
            if t.resolved not in intercepted:
                specs[RelaySpec(internal_name(model, t.resolved), t.resolved, t.type, run_at(t.resolved))] = None
            elif model.topic(t.resolved, "publish", "new") is None:
                # W takes T over: its handler writes what reaches T (write(T), as in the paper); T is
                # latched if B's output is, unless the declaration says how T is published
                follows = None if t.latch or t.qos else internal_name(model, t.resolved)
                specs[PublishSpec(t.resolved, t.type, t.latch, qos_of(t.qos), follows)] = None
        elif t.resolved not in intercepted:  # reuse subscribe: the world into B
            specs[RelaySpec(t.resolved, internal_name(model, t.resolved), t.type, placed)] = None

    for timer in model.timers:
        specs[TimerSpec(timer.name, timer.period, timer.oneshot, timer_slot(timer.name))] = None

    served = {s.resolved for s in model.services if s.role == "new"}
    for s in model.services:
        if s.role == "new":
            specs[ServiceSpec(s.resolved, s.type, service_slot(s.resolved))] = None
        elif s.resolved not in served:
            specs[ServiceRelaySpec(internal_name(model, s.resolved), s.resolved, s.type, placed)] = None

    reused = {a.resolved for a in model.actions if a.role == "reuse"}
    handled = {a.resolved for a in model.actions if a.role == "new"}
    for a in model.actions:
        if a.role == "new":
            forward = internal_name(model, a.resolved) if a.resolved in reused else None
            specs[ActionServerSpec(a.resolved, a.type, action_slot(a.resolved), forward)] = None
        elif a.resolved not in handled:
            specs[ActionRelaySpec(internal_name(model, a.resolved), a.resolved, a.type, placed)] = None
    return specs


def write_target(model: NodeModel, resolved: str) -> str | None:
    """Where ``write(resolved)`` sends: its own publication (declared, or an intercepted output of B
    taken over), or B's input for a reused subscription."""
    for t in model.topics:
        if t.resolved == resolved and t.role == "new" and t.direction == "publish":
            return resolved
    intercepted = model.topic(resolved, "subscribe", "new") is not None
    if intercepted and model.topic(resolved, "subscribe", "reuse") is not None:
        return internal_name(model, resolved)
    if intercepted and model.topic(resolved, "publish", "reuse") is not None:
        return resolved
    return None
