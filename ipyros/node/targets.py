"""What a name is on a node when a handler is asked for: a subscription, a timer, a service, an action, or a
relayed topic a handler may take over (``%handler``, ``nd.versions``, ``nd.revert``, ``%try``).

Pure functions of the node's model and its name resolution: the engine asks, the tools show.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Optional

from ..core import plan as planning
from ..core.errors import NotDeclaredError, TopicNameError
from ..core.model import NodeModel

__all__ = ["HandlerTarget", "find_target", "relayed_target"]

#: How a node resolves a name of a kind (its engine's ``resolve``).
Resolve = Callable[[str, str], str]


@dataclass(frozen=True)
class HandlerTarget:
    """Something on a node that calls a handler: a subscription, a timer, a service or an action."""

    kind: str  # "topic", "timer", "service", "action", or "relay" (a relayed topic a handler takes over)
    name: str  # as declared: the topic/service name as typed, or the timer's name
    slot: str  # the node's handler slot key (see ipyros.core.plan): where its versions are kept

    @property
    def label(self) -> str:
        return self.name if self.kind == "topic" else f"{self.kind} {self.name}"


def _resolved(resolve: Resolve, name: str) -> Optional[str]:
    try:
        return resolve(name, "topic")
    except TopicNameError:  # not a graph name: only a timer can be called that ("<lambda>")
        return None


def find_target(model: NodeModel, resolve: Resolve, name: str, called: str) -> HandlerTarget:
    """What ``name`` (a topic, a timer name, a service or an action) is on the node, if it has a handler; else a
    one-line error listing its handlers (``called``: how the user calls the node, for the advice)."""
    resolved = _resolved(resolve, name)
    if resolved is not None:
        topic = model.topic(resolved, "subscribe", "new")
        if topic is not None:
            return HandlerTarget("topic", topic.name, planning.topic_slot(resolved))
        service = next((s for s in model.services if s.resolved == resolved and s.role == "new"), None)
        if service is not None:
            return HandlerTarget("service", service.name, planning.service_slot(resolved))
        action = model.action(resolved, "new")
        if action is not None:
            return HandlerTarget("action", action.name, planning.action_slot(resolved))
    timer = model.timer(name)
    if timer is not None:
        return HandlerTarget("timer", timer.name, planning.timer_slot(timer.name))
    handlers = [f"{t.resolved} ({t.handler})" for t in model.subscriptions() if t.role == "new"]
    handlers += [f"timer {t.name} ({t.handler})" for t in model.timers]
    handlers += [f"service {s.resolved} ({s.handler})" for s in model.services if s.role == "new"]
    handlers += [f"action {a.resolved} ({a.handler})" for a in model.actions if a.role == "new"]
    relayed = next((t for t in model.topics if t.resolved == resolved and t.role == "reuse"), None)
    if relayed is not None:  # a wrapped topic passed on unchanged: a handler is declared with new
        raise NotDeclaredError(
            f"{model.name} relays {resolved} unchanged (reuse), with no handler to edit; to handle it, "
            f"declare one: {called}.new.subscribe({relayed.name!r}, handler, msgType={relayed.type!r})")
    known = "; its handlers: " + ", ".join(handlers) if handlers else (
        f"; it has no handlers yet: declare one, e.g. {called}.new.subscribe(TOPIC, handler, msgType=...)")
    raise NotDeclaredError(f"{model.name} has no handler for {resolved or name}{known}")


def relayed_target(model: NodeModel, resolve: Resolve, name: str) -> Optional[HandlerTarget]:
    """``name`` as a topic the node only relays (``reuse``, no handler yet), as a target a handler can take over
    (``%handler`` offers a pass-through to start from); None if it is not one."""
    resolved = _resolved(resolve, name)
    if resolved is None:
        return None
    relayed = next((t for t in model.topics if t.role == "reuse" and name in (t.name, t.resolved)), None) or \
        next((t for t in model.topics if t.role == "reuse" and t.resolved == resolved), None)
    if relayed is None or model.topic(relayed.resolved, "subscribe", "new") is not None:
        return None
    return HandlerTarget("relay", relayed.name, planning.topic_slot(relayed.resolved))


def handler_slots(resolve: Resolve, name: str) -> tuple[str, ...]:
    """The slot keys a handler of ``name`` may be kept under: its subscription, service, action, or a timer so named."""
    resolved = _resolved(resolve, name)
    keys = (planning.topic_slot(resolved), planning.service_slot(resolved),
            planning.action_slot(resolved)) if resolved is not None else ()
    return (*keys, planning.timer_slot(name))
