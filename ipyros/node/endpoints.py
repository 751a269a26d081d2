"""Opening the endpoints a node's plan lists: one opener per kind of endpoint, through the session's backend.

:func:`ipyros.core.plan.plan` says which endpoints a node needs (a :data:`~ipyros.core.plan.Spec`
each); :data:`OPENERS` says how each kind is opened on the backend, so that a new kind of
endpoint is a row here and a method of the backend, not another branch in the engine.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, Callable

from ..core import msgtypes, plan as planning
from ..core.errors import DeclarationError, IpyrosError, MessageTypeError, first_line
from ..core.plan import Spec
from ..core.slots import HandlerSlot

__all__ = ["OPENERS", "Opening", "describe", "open_endpoint", "output_of", "publication_of"]


@dataclass(frozen=True)
class Opening:
    """What opening an endpoint of one node needs: the backend, the node's ROS name, how it says what goes wrong."""

    backend: Any
    host: str  # the node's full name
    node: str  # its name, for what is said
    complain: Callable[[str], None]  # a live endpoint's trouble, told at the prompt under the node's name
    notify: Callable[[str], None]  # a line of the session's own
    slot: Callable[[Any], HandlerSlot]  # the handler slot that serves a spec (made on first use)
    gate: Callable[[str], Any] = lambda topic: None  # the guard an output of a topic passes its messages through
    guard: Callable[[Any], Any] = lambda spec: None  # a guard opened (its process started)
    placed: Callable[[Any], Any] = lambda spec: None  # a relay a machine's keeper runs (its spec names the machine)


def _publication(at: Opening, spec: planning.PublishSpec) -> Any:
    qos = replace(spec.qos, durability="transient_local") if spec.latch else spec.qos
    return at.backend.publication(at.host, spec.topic, msgtypes.resolve_message(spec.type)[1], qos, at.complain,
                                  spec.follows, gate=at.gate(spec.topic))


def _relay(at: Opening, spec: planning.RelaySpec) -> Any:
    if spec.machine is not None:  # beside its basenode, on that machine (see ipyros.node.placedrelay)
        return at.placed(spec)

    def wrong_type(got: str) -> None:
        at.notify(f"ipyros: {spec.source} carries {got}, but {at.node} relays it as {spec.type}; messages are "
                  f"dropped: declare type={got!r}")

    try:
        cls = msgtypes.resolve_message(spec.type)[1]
    except MessageTypeError:
        if not at.backend.relays_any_type or at.gate(spec.target) is not None:  # a guard reads what it checks
            raise
        return at.backend.raw_relay(at.host, spec.source, spec.target, spec.type, wrong_type, at.complain)
    return at.backend.relay(at.host, spec.source, spec.target, cls, wrong_type, at.complain, gate=at.gate(spec.target))


def _service_relay(at: Opening, spec: planning.ServiceRelaySpec) -> Any:
    if spec.machine is not None:
        return at.placed(spec)
    return at.backend.service_relay(at.host, spec.source, spec.target, msgtypes.resolve_service(spec.type)[1],
                                    at.complain)


def _action_relay(at: Opening, spec: planning.ActionRelaySpec) -> Any:
    if spec.machine is not None:
        return at.placed(spec)

    def wrong_part(got: str) -> None:
        at.notify(f"ipyros: a part of action {spec.source} carries {got}, but {at.node} relays it as {spec.type}; "
                  "its messages are dropped: declare the action's own type")

    return at.backend.action_relay(at.host, spec.source, spec.target, msgtypes.resolve_action(spec.type)[1],
                                   wrong_part, at.complain)


def _subscription(at: Opening, spec: planning.SubscribeSpec) -> Any:
    return at.backend.subscription(at.host, spec.topic, msgtypes.resolve_message(spec.type)[1], at.slot(spec),
                                   spec.qos, at.complain)


def _timer(at: Opening, spec: planning.TimerSpec) -> Any:
    return at.backend.timer(at.host, spec.period, at.slot(spec), spec.oneshot, at.complain)


def _action_server(at: Opening, spec: planning.ActionServerSpec) -> Any:
    return at.backend.action_server(at.host, spec.name, msgtypes.resolve_action(spec.type)[1], at.slot(spec),
                                    spec.forward)


def _service(at: Opening, spec: planning.ServiceSpec) -> Any:
    return at.backend.service(at.host, spec.name, msgtypes.resolve_service(spec.type)[1], at.slot(spec))


def _guard(at: Opening, spec: planning.GuardSpec) -> Any:
    return at.guard(spec)


#: Each kind of endpoint, what it is called in a few words, and how it is opened.
OPENERS: dict[type, tuple[str, Callable[[Opening, Any], Any]]] = {
    planning.GuardSpec: ("guard", _guard),
    planning.PublishSpec: ("publisher", _publication),
    planning.SubscribeSpec: ("subscriber", _subscription),
    planning.RelaySpec: ("relay", _relay),
    planning.TimerSpec: ("timer", _timer),
    planning.ServiceSpec: ("service", _service),
    planning.ServiceRelaySpec: ("service relay", _service_relay),
    planning.ActionServerSpec: ("action server", _action_server),
    planning.ActionRelaySpec: ("action relay", _action_relay),
}


def open_endpoint(at: Opening, spec: Spec) -> Any:
    """The live endpoint for ``spec``; the client library's own complaint made one line."""
    try:
        return OPENERS[type(spec)][1](at, spec)
    except IpyrosError:
        raise
    except Exception as error:  # the client library's own complaint, made one line
        raise DeclarationError(f"cannot open {describe(spec)}: {first_line(error)}") from None


def output_of(spec: Spec) -> Any:
    """The topic an endpoint sends to the world on (a publication's, a relay's target), or None."""
    if isinstance(spec, planning.PublishSpec):
        return spec.topic
    return spec.target if isinstance(spec, planning.RelaySpec) else None


def publication_of(live: dict[Spec, Any], topic: str) -> Any:
    """The open publication of ``topic`` among a node's ``live`` endpoints (what ``write`` sends through)."""
    return next(endpoint for spec, endpoint in live.items()
                if isinstance(spec, planning.PublishSpec) and spec.topic == topic)


def describe(spec: Spec) -> str:
    """``publisher /x``, ``relay /a -> /b``: an endpoint of the plan in a few words."""
    kind = OPENERS[type(spec)][0]
    source = getattr(spec, "source", None)
    if source is not None:
        return f"{kind} {source} -> {spec.target}"  # type: ignore[union-attr]
    return f"{kind} {getattr(spec, 'topic', None) or getattr(spec, 'name', '')}"
