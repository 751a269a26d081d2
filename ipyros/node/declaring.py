"""Declaring: every checked edit of a node's model, as a function over its engine.

Whoever declares something on a node goes through here: the DSL (``nd.new.subscribe(...)``,
``nd.timer(...)``, ``nd.remove(...)``; :mod:`ipyros.dsl` only spells these calls: chains, the
paper's attribute spelling, what a chain shows), ``%handler`` and reverts (the engine's
``redeclare``), discovery and ``%wrap`` (:func:`ipyros.node.baseinterface.declare_interface`). So
a declaration is checked the same whoever makes it, and the calls run down the layers only.

Each function checks its input, hands the engine one edit of the model (all or nothing, live
at once if the node runs: :meth:`~ipyros.node.engine.NodeEngine.change`), records it in the
history and returns what it did in a few words (a DSL chain lists them when a later call fails).
``role`` is ``"new"`` or ``"reuse"`` (the paper's two kinds of declaration).
"""

from __future__ import annotations

import importlib.util
import re
from typing import Any, Callable, Optional, Protocol

from ..core import msgtypes, plan as planning, qos as qos_mod
from ..core.errors import DeclarationError, HandlerError, MessageTypeError, NotDeclaredError, TopicTypeConflict, cut
from ..core.guard import (DEFAULT_GRACE, DEFAULT_LEASE, DEFAULT_MACHINE_GRACE, DEFAULT_REPEAT, ESTOP_TYPE, check_rules,
                          check_stop)
from ..core.model import ActionModel, GuardModel, NodeModel, Role, ServiceModel, TimerModel, TopicModel
from ..core.msgbuild import as_data, build_message
from ..core.remapping import check_reuse
from ..core.rules import Rule, RuleSet, as_rule, compile_condition
from ..core.slots import call_arity
from ..core.versions import name_of
from ..processes.keeper import MachineError, Token, check_machine_name, token_path



class DeclaringNode(Protocol):
    """What declaring needs of a node (its :class:`~ipyros.node.engine.NodeEngine`, which declares through here:
    named as a protocol, so that this module does not import the engine back)."""

    @property
    def name(self) -> str: ...
    session: Any

    def model(self) -> NodeModel: ...
    def resolve(self, name: str, kind: str = "topic") -> str: ...
    def resolve_as(self, role: str, name: str, kind: str) -> str: ...
    def change(self, edit: Callable[[NodeModel], None], handlers: Any = None, drop: Any = (),
               check: Any = ()) -> None: ...
    def record(self, change: str) -> None: ...


__all__ = ["MIN_TIMER_PERIOD", "drop", "guard", "publish", "redeclare", "remove", "serve", "subscribe", "timer"]

MIN_TIMER_PERIOD = 1e-4  # seconds; below it a timer would only spin a core (and rospy divides by it)


# -- topics ---------------------------------------------------------------------------------------

def subscribe(engine: DeclaringNode, role: Role, topic: str, handler: Optional[Callable[..., Any]], msg_type: Any,
              qos: Any = None) -> str:
    """Subscribe ``handler(msg)`` to ``topic`` (``new``), or relay the basenode's input (``reuse``); declared again,
    the handler is swapped live."""
    resolved = engine.resolve_as(role, topic, "topic")
    type_name = _type_name(engine, msg_type, relayed=role == "reuse" and handler is None)
    given = _qos(role, qos, f"{role}.subscribe({topic!r})")
    if role == "reuse":
        check_reuse(engine.model(), resolved, "subscribe")
    handlers = {}
    if role == "new":
        if handler is None:
            raise HandlerError(f"new.subscribe({topic!r}) needs handler=...: the function called with each message")
        handlers[planning.topic_slot(resolved)] = (handler, call_arity(handler, "subscribe",
                                                                        f"{engine.name} {resolved}"))
    elif handler is not None:
        raise HandlerError(f"reuse.subscribe({topic!r}) relays messages unchanged and takes no handler; "
                           "to handle them use new.subscribe(..., handler=...)")
    entry = TopicModel(topic, resolved, "subscribe", type_name, role, name_of(handler), qos=given.to_model())
    before = engine.model().topic(resolved, "subscribe", role)  # declared again: a swap, said as one
    engine.change(_replace_topic(entry), handlers, check=(entry,))
    if before is not None and before.type == type_name and before.handler and handler is not None:
        return _done(engine, role, f"subscribe {resolved}: handler {before.handler} → {entry.handler}")
    return _done(engine, role, f"subscribe {resolved} [{type_name}]" + (f" -> {entry.handler}" if handler else ""))


def publish(engine: DeclaringNode, role: Role, topic: str, msg_type: Any, latch: bool = False, qos: Any = None) -> str:
    """Publish ``topic`` (``new``: ``write`` sends on it), or relay the basenode's output (``reuse``)."""
    resolved = engine.resolve_as(role, topic, "topic")
    type_name = _type_name(engine, msg_type, relayed=role == "reuse")
    where = f"{role}.publish({topic!r})"
    given = _qos(role, qos, where)
    if latch and given.durability == "volatile":
        raise DeclarationError(f"{where}: latch=True and a volatile qos contradict each other; "
                               "drop one (latch=True is qos durability transient_local)")
    if role == "reuse":
        check_reuse(engine.model(), resolved, "publish")
    entry = TopicModel(topic, resolved, "publish", type_name, role, None, bool(latch), given.to_model())
    engine.change(_replace_topic(entry), check=(entry,))
    return _done(engine, role, f"publish {resolved} [{type_name}]")


def drop(engine: DeclaringNode, role: str, topic: str, direction: str) -> str:
    """Drop this role's subscription (``direction="subscribe"``) or publication of ``topic``."""
    resolved = engine.resolve_as(role, topic, "topic")
    if engine.model().topic(resolved, direction, role) is None:  # type: ignore[arg-type]
        raise NotDeclaredError(f"{engine.name} has no {role}.{direction} of {resolved}")
    if direction == "publish":
        _refuse_unguarding(engine, resolved, f"{role}.unpublish({topic!r})")

    def edit(model: NodeModel) -> None:
        model.topics = [t for t in model.topics
                        if not (t.resolved == resolved and t.direction == direction and t.role == role)]

    engine.change(edit, drop=[planning.topic_slot(resolved)] if direction == "subscribe" and role == "new" else [])
    return _done(engine, role, f"removed {direction} {resolved}")


def _replace_topic(entry: TopicModel) -> Callable[[NodeModel], None]:
    """An edit that declares ``entry``, replacing the same topic/direction/role if declared."""

    def edit(model: NodeModel) -> None:
        for other in model.topics:
            if other.resolved == entry.resolved and other.type != entry.type and \
                    (other.direction, other.role) != (entry.direction, entry.role):
                raise TopicTypeConflict(
                    f"{entry.resolved} is already declared as {other.role}.{other.direction} with {other.type}; "
                    f"use the same type, or remove it first ({model.name}.remove({entry.name!r}))")
        model.topics = [t for t in model.topics
                        if not (t.resolved == entry.resolved and t.direction == entry.direction
                                and t.role == entry.role)]
        model.topics.append(entry)

    return edit


def _type_name(engine: DeclaringNode, msg_type: Any, relayed: bool) -> str:
    """The declared type's name; a type this Python cannot import is taken, as ``pkg/Type``, only for a relay: a
    handler or a publisher needs its class, a relay does not (ROS 1 relays bytes of any type) or gets it from
    the basenode before it opens (ROS 2: :func:`~ipyros.node.baseinterface.learn_relayed_types`)."""
    try:
        return msgtypes.resolve_message(msg_type)[0]
    except MessageTypeError:
        if not (relayed and isinstance(msg_type, str) and re.fullmatch(r"\w+/(msg/)?\w+", msg_type.strip())):
            raise
        package, _, name = msg_type.strip().partition("/")
        if not engine.session.backend.relays_any_type and importlib.util.find_spec(package) is not None:
            raise  # the package is here, the name is wrong: the error says which names it has
        return f"{package}/{name.rsplit('/', 1)[-1]}"


def _qos(role: str, value: Any, where: str) -> qos_mod.Qos:
    """``qos=`` checked; refused on reuse, whose relays take the QoS of what they relay."""
    if value is not None and role == "reuse":
        raise DeclarationError(f"{where}: a reuse relay takes the QoS of the publishers it relays and "
                               "takes no qos=; give qos= to new.subscribe or new.publish")
    return qos_mod.parse(value, where)


# -- services and actions -------------------------------------------------------------------------

#: What each served kind is called with, returns, and how the reuse of it is changed instead (for its errors).
_SERVED = {"service": ("called with each request, returns the response", "to answer it yourself"),
           "action": ("called with each goal, returns the result", "to serve or change its goals")}


def serve(engine: DeclaringNode, role: Role, kind: str, name: str, type_: Any,
          handler: Optional[Callable[..., Any]]) -> str:
    """A service or an action (``kind``): served by ``handler`` (new) or relayed from the basenode (reuse).

    Both are a name, a type and a handler slot; declared again they swap the handler live, and a
    ``new`` and a ``reuse`` of one name must agree on its type.
    """
    type_name = (msgtypes.resolve_service if kind == "service" else msgtypes.resolve_action)(type_)[0]
    resolved = engine.resolve_as(role, name, kind)
    slot = (planning.service_slot if kind == "service" else planning.action_slot)(resolved)
    does, instead = _SERVED[kind]
    handlers = {}
    if role == "new":
        if handler is None:
            raise HandlerError(f"new.{kind}({name!r}) needs handler=...: {does}")
        handlers[slot] = (handler, call_arity(handler, kind, f"{engine.name} {resolved}"))
    elif handler is not None:
        raise HandlerError(f"reuse.{kind}({name!r}) relays the basenode's {kind} and takes no handler; "
                           f"{instead} use new.{kind}(..., handler=...)")
    entry = (ServiceModel if kind == "service" else ActionModel)(name, resolved, type_name, role, name_of(handler))
    field = "services" if kind == "service" else "actions"

    def edit(model: NodeModel) -> None:
        declared = getattr(model, field)
        other = next((d for d in declared if d.resolved == resolved and d.type != type_name), None)
        if other is not None:
            raise TopicTypeConflict(f"{kind} {resolved} is already declared as {other.role}.{kind} with "
                                    f"{other.type}; use the same type, or remove it first "
                                    f"({model.name}.remove({kind}={name!r}))")
        setattr(model, field, [d for d in declared if not (d.resolved == resolved and d.role == role)] + [entry])

    engine.change(edit, handlers)
    return _done(engine, role, f"{kind} {resolved} [{type_name}]" + (f" -> {entry.handler}" if handler else ""))


# -- timers ---------------------------------------------------------------------------------------

def timer(engine: DeclaringNode, period: Any, handler: Callable[..., Any], name: Optional[str] = None,
          oneshot: bool = False) -> str:
    """Call ``handler`` every ``period`` seconds (once if ``oneshot``); a timer of the same ``name`` (default: the
    handler's name) is replaced."""
    if (isinstance(period, bool) or not isinstance(period, (int, float))
            or not MIN_TIMER_PERIOD <= period < float("inf")):
        raise DeclarationError(f"timer period must be a number of seconds from {MIN_TIMER_PERIOD:g} "
                               f"(10 kHz) up, not {cut(period)}")
    name = name or getattr(handler, "__name__", "timer")
    if not isinstance(name, str) or not (re.fullmatch(r"\w+", name) or name == "<lambda>"):
        raise DeclarationError(f"timer name {cut(name)}: give letters, digits and _, e.g. name='heartbeat'")
    takes_event = call_arity(handler, "timer", f"{engine.name} timer {name}")
    entry = TimerModel(name=name, period=float(period), handler=name_of(handler) or "timer", oneshot=oneshot)

    def edit(model: NodeModel) -> None:
        model.timers = [t for t in model.timers if t.name != name] + [entry]

    engine.change(edit, {planning.timer_slot(name): (handler, takes_event)})
    text = f"timer {name} every {float(period):g} s -> {entry.handler}" + (" once" if oneshot else "")
    engine.record(text)
    return text


# -- guards ---------------------------------------------------------------------------------------

def guard(engine: DeclaringNode, topic: str, limits: Any = None, rate: Any = None, on_limit: str = "clamp",
          timeout: Any = None, stop: Any = None, repeat: Any = DEFAULT_REPEAT, grace: Any = DEFAULT_GRACE,
          estop_topic: Optional[str] = None, machine: Optional[str] = None, lease: Any = None,
          machine_grace: Any = DEFAULT_MACHINE_GRACE, rules: Any = None, stale: Any = None) -> str:
    """A safety guard on the output ``topic`` (see :mod:`ipyros.core.guard`); declared again, its rules change live
    (nothing reopens: no message is lost or sent unguarded). ``machine``: kept by that machine's keeper."""
    where = f"{engine.name}.guard({topic!r})"
    model = engine.model()
    resolved = engine.resolve(topic)
    output = next((t for t in model.outputs()
                   if t.name == topic or t.resolved in (resolved, engine.resolve_as(t.role, topic, "topic"))), None)
    if output is None:
        outs = ", ".join(t.resolved for t in model.outputs()) or "none yet"
        raise NotDeclaredError(f"{where}: {engine.name} sends nothing on {resolved} (its outputs: {outs}); a guard "
                               "stands on an output: declare it first (new.publish, or reuse.publish of its basenode)")
    try:
        cls = msgtypes.resolve_message(output.type)[1]
    except MessageTypeError:
        raise MessageTypeError(f"{where}: a guard reads the values it checks, and {output.type} is not installed "
                               f"here ({msgtypes.install_hint(output.type.split('/')[0])})") from None
    limits_, rates = check_rules(cls, limits, rate, on_limit, timeout, grace, repeat, where)
    stop_message = build_message(cls, stop) if stop is not None else cls()  # checked field by field
    check_stop(cls, stop_message, limits_, where, given=stop is not None)
    if stop is not None:
        stop = as_data(stop_message)  # kept as data (a model file's)
    estop = engine.resolve(estop_topic) if estop_topic is not None else None
    taken = next((t for t in model.topics if t.resolved == estop and t.type != ESTOP_TYPE), None)
    if taken is not None:
        raise TopicTypeConflict(f"{where}: estop_topic {estop} carries {taken.type} on {engine.name}, not "
                                f"{ESTOP_TYPE}: an e-stop topic is a {ESTOP_TYPE} of its own; give it another name")
    given_rules, stale_ = _sensed_rules(engine, where, cls, output.resolved, stop_message, rules, stale, machine)
    lease, machine_grace = _placement(where, machine, lease, machine_grace)
    before = model.guard(output.resolved)
    if before is not None and before.machine != machine:
        raise DeclarationError(f"{where}: the guard of {output.resolved} is kept by "
                               f"{before.machine and 'machine ' + before.machine or 'this session'}; it moves only "
                               f"when removed first: {engine.name}.remove(guard={output.resolved!r}), then declared")
    entry = GuardModel(topic, output.resolved, output.type, {p: list(b) for p, b in limits_.items()}, rates, on_limit,
                       float(timeout) if timeout is not None else None, stop, float(repeat), float(grace), estop,
                       machine, lease, machine_grace, [r.as_data() for r in given_rules], stale_)

    def edit(model: NodeModel) -> None:
        model.guards = [g for g in model.guards if g.resolved != output.resolved] + [entry]

    engine.change(edit)
    said = [f"limits {', '.join(f'{p} {b[0]:g}..{b[1]:g}' for p, b in limits_.items())}" if limits_ else "",
            f"rate {', '.join(f'{p} {m:g}/s' for p, m in rates.items())}" if rates else "",
            f"stop after {timeout:g} s of silence" if timeout is not None else "", on_limit if limits_ else "",
            f"e-stop topic {estop}" if estop else "",
            f"kept by machine {machine} (lease {lease:g} s)" if machine else "",
            "; ".join(str(r) for r in given_rules),
            f"stale after {', '.join(f'{t} {s:g} s' for t, s in stale_.items())}" if stale_ else ""]
    text = f"guard {output.resolved}: " + ("; ".join(s for s in said if s) or "NaN and infinities stopped")
    engine.record(text)
    return text


def _sensed_rules(engine: DeclaringNode, where: str, cls: type, output: str, stop_message: Any, rules: Any, stale: Any,
                  machine: Optional[str]) -> tuple[list[Rule], dict[str, float]]:
    """A guard's rules over what the robot senses (``rule(...)`` or their data), compiled against the guarded type
    and the inputs' types the graph knows, and the stop message checked against them; each refusal one line."""
    if rules is None and stale is None:
        return [], {}
    if rules is not None and not isinstance(rules, (list, tuple)):
        raise DeclarationError(f"{where}: rules={cut(rules)}: give a list of rule(...), e.g. "
                               "rules=[rule('min(/scan.ranges) < 0.5', limit={'linear.x': (-0.2, 0.2)})]")
    if stale is not None and not isinstance(stale, dict):
        raise DeclarationError(f"{where}: stale={cut(stale)}: give a dict of input topics and seconds, e.g. "
                               "stale={'/scan': 0.3}")
    given = [as_rule(r, where) for r in rules or ()]
    stale_ = {engine.resolve(str(t)) if isinstance(t, str) else t: s for t, s in (stale or {}).items()}
    ruleset = RuleSet(given, cls, output, stale_, where, _known_types(engine, given, stale_))
    ruleset.check_stop(stop_message, where)
    return given, {t: float(s) for t, s in stale_.items()}


def _known_types(engine: DeclaringNode, rules: list[Rule], stale: dict[str, Any]) -> dict[str, Any]:
    """The message classes of the inputs the live graph (or the node itself) knows and this Python has."""
    topics = {p.topic for r in rules for p in compile_condition(r.condition, "").inputs} | set(stale)
    try:
        live = engine.session.backend.graph_snapshot(timeout=0.5).topics
    except Exception:  # noqa: BLE001 - no graph to ask: the types are checked at the first message
        live = {}
    found = {}
    for topic in topics:
        name = live.get(topic) or next((t.type for t in engine.model().topics if t.resolved == topic), None)
        cls = msgtypes.message_class_or_none(name) if name else None
        if cls is not None:
            found[topic] = cls
    return found


def _placement(where: str, machine: Any, lease: Any, grace: Any) -> tuple[float, Optional[float]]:
    """A guard's placement on a machine checked (its name, the token this session signs with, its lease); each
    refusal one line. Returns the lease and the grace as numbers."""
    if machine is None:
        if lease is not None or grace != DEFAULT_MACHINE_GRACE:
            raise DeclarationError(f"{where}: lease= and machine_grace= are for a guard kept by another machine: "
                                   "give machine='robot1' too, or leave them out")
        return DEFAULT_LEASE, DEFAULT_MACHINE_GRACE
    try:
        check_machine_name(machine)
        Token.read(token_path(machine), machine)  # said now, not when the node starts
    except MachineError as error:
        raise DeclarationError(f"{where}: {error}") from None
    lease = DEFAULT_LEASE if lease is None else lease
    if not _positive(lease) or lease > 10:
        raise DeclarationError(f"{where}: lease={cut(lease)}: give the seconds the robot waits to hear this session "
                               "before it holds the stop message, more than 0 and at most 10 (e.g. 0.5)")
    if grace is not None and (not _positive(grace) or grace < lease):
        raise DeclarationError(f"{where}: machine_grace={cut(grace)}: give the seconds after which the robot ends a "
                               f"guard whose session is silent, at least the lease ({lease:g}), or None to keep it")
    return float(lease), None if grace is None else float(grace)


def _positive(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and 0 < value < float("inf")


def _refuse_unguarding(engine: DeclaringNode, resolved: str, what: str) -> None:
    """A guarded output is not removed by accident: its guard goes first, by its own call."""
    if engine.model().guard(resolved) is not None:
        raise DeclarationError(f"{what} would remove {resolved}, which is guarded; remove its guard first, by its "
                               f"own call: {engine.name}.remove(guard={resolved!r})")


# -- removal --------------------------------------------------------------------------------------

#: Each kind's list in the model and its handler slot (a timer is found by its name, the rest by global name).
_REMOVABLE = {"topic": ("topics", planning.topic_slot), "timer": ("timers", planning.timer_slot),
              "service": ("services", planning.service_slot), "action": ("actions", planning.action_slot),
              "guard": ("guards", None)}


def remove(engine: DeclaringNode, kind: str, name: str) -> str:
    """Remove every declaration of the topic ``name``, or the timer, service or action of that name."""
    field, slot = _REMOVABLE[kind]
    key = name if kind == "timer" else engine.resolve(name, "topic" if kind == "guard" else kind)
    of = (lambda entry: entry.name) if kind == "timer" else (lambda entry: entry.resolved)
    declared = getattr(engine.model(), field)
    if not any(of(entry) == key for entry in declared):
        known = ", ".join(dict.fromkeys(of(entry) for entry in declared)) or "none"
        shown = repr(key) if kind == "timer" else key
        raise NotDeclaredError(f"{engine.name} has no {kind} {shown} ({field}: {known})")
    if kind == "topic" and any(t.resolved == key and t.direction == "publish" for t in declared):
        _refuse_unguarding(engine, key, f"remove({name!r})")
    engine.change(lambda m: setattr(m, field, [e for e in getattr(m, field) if of(e) != key]),
                  drop=[slot(key)] if slot is not None else [])
    text = f"remove {'' if kind == 'topic' else kind + ' '}{key}"
    engine.record(text)
    return text


# -- a handler swapped in (%handler, a revert) ----------------------------------------------------

def redeclare(engine: DeclaringNode, target: Any, handler: Callable[..., Any]) -> str:
    """Declare ``target`` (a :class:`~ipyros.node.targets.HandlerTarget`) again exactly as it is, but served by
    ``handler``: a live swap, as the DSL does it."""
    model = engine.model()
    if target.kind == "relay":  # a relayed topic taken over: new.subscribe spelled as its reuse intercepts it
        relayed = next((t for t in model.topics if t.role == "reuse" and t.name == target.name), None)
        if relayed is None:
            raise NotDeclaredError(f"{engine.name} no longer relays {target.name}")
        return subscribe(engine, "new", relayed.name, handler, relayed.type)
    if target.kind == "topic":
        topic = model.topic(engine.resolve(target.name), "subscribe", "new")
        if topic is None:
            raise NotDeclaredError(f"{engine.name} no longer subscribes to {target.name}")
        return subscribe(engine, "new", topic.name, handler, topic.type, topic.qos)
    if target.kind == "timer":
        found_timer = model.timer(target.name)
        if found_timer is None:
            raise NotDeclaredError(f"{engine.name} no longer has the timer {target.name}")
        return timer(engine, found_timer.period, handler, found_timer.name, found_timer.oneshot)
    resolved = engine.resolve(target.name, target.kind)  # a service or an action
    served = model.services if target.kind == "service" else model.actions
    found = next((s for s in served if s.resolved == resolved and s.role == "new"), None)
    if found is None:
        raise NotDeclaredError(f"{engine.name} no longer serves {'the action ' * (target.kind == 'action')}"
                               f"{target.name}")
    return serve(engine, "new", target.kind, found.name, found.type, handler)


def _done(engine: DeclaringNode, role: str, text: str) -> str:
    """Record ``role.text`` in the history; ``text`` is what the declaration did."""
    engine.record(f"{role}.{text}")
    return text
