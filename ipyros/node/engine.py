"""What makes a DSL node live: its model, its handlers and their versions, its slots, its open endpoints.

A :class:`~ipyros.dsl.rosnode.rosNode` is the user's DSL and nothing else (``nd.<TAB>`` shows
the paper's methods); each one owns a :class:`NodeEngine`, which holds its state and is the
one place where the model and the running node change: :meth:`NodeEngine.change` edits a
copy of the model, and if the node runs, reconciles the live endpoints with the plan of
the new model (:mod:`ipyros.core.plan`) through the session's backend, then commits. A
rejected change leaves model and running node as they were.

ipyros's own modules (wrapping, saving and exporting, the tools and the magics) use a node
through its engine (:func:`ipyros.dsl.engine_of`), never through private fields.
"""

from __future__ import annotations

import copy
import threading
import time
from dataclasses import dataclass, replace
from typing import Any, Callable, Optional

from ..core import msgtypes, names, plan as planning, versions as versions_mod
from ..core.errors import (
    DeclarationError,
    IpyrosError,
    MessageTypeError,
    NodeStateError,
    NotDeclaredError,
    TopicNameError,
    TopicTypeConflict,
    first_line,
)
from ..core.model import NodeModel, TopicModel
from ..core.plan import Spec
from ..core.records import History, NodeStatus, StatusRow, Versions
from ..core.remapping import base_fullname, basenode_remaps, check_wrapping, resolve_for
from ..core.slots import HandlerSlot, OutputScope, SendFigures
from ..core.versions import HandlerVersion
from .session import Session
from .wrapping import interrupted, learn_relayed_types, start_base

#: A slot key's new handler and whether it takes the message (or timer event) as its argument.
Handlers = dict[str, tuple[Callable[..., Any], bool]]

__all__ = ["HandlerTarget", "NodeEngine"]


@dataclass(frozen=True)
class HandlerTarget:
    """Something on a node that calls a handler: a subscription, a timer, a service or an action."""

    kind: str  # "topic", "timer", "service", "action", or "relay" (a relayed topic a handler takes over)
    name: str  # as declared: the topic/service name as typed, or the timer's name
    slot: str  # the node's handler slot key (see ipyros.core.plan): where its versions are kept

    @property
    def label(self) -> str:
        return self.name if self.kind == "topic" else f"{self.kind} {self.name}"


class NodeEngine:
    """The state of one DSL node and the changes to it; see the module's docstring."""

    def __init__(self, dsl: Any, model: NodeModel, session: Session, explicit_namespace: bool) -> None:
        self.dsl = dsl  # the rosNode the user holds (advice names its variable; tools hand it back)
        self.session = session
        #: Whether the namespace was given; a wrapping node without one lives in its basenode's.
        self.explicit_namespace = explicit_namespace
        self.created = False
        #: The running basenode (a process, or a launch file's rest and node), for wrapping nodes.
        self.base: Any = None
        self._model = model
        self._handlers: dict[str, Callable[..., Any]] = {}  # slot key → the user's function
        self._takes_argument: dict[str, bool] = {}  # slot key → call the handler with the message/event?
        self._slots: dict[str, HandlerSlot] = {}
        self._output: Optional[OutputScope] = None  # where its handlers print (the creating cell, in Jupyter)
        self._live: dict[Spec, Any] = {}  # spec → runtime endpoint
        self._writers: dict[str, tuple[Any, str]] = {}  # topic as typed → (publication, type)
        self._versions: dict[str, list[HandlerVersion]] = {}  # slot key → every function it was given
        self._current_version: dict[str, int] = {}  # slot key → number of the version serving it
        self._reverting: Optional[int] = None  # set while revert() re-declares an old version
        self._new_version: Optional[tuple[str, HandlerVersion]] = None  # for the next record()
        self._lock = threading.RLock()
        self._param_handlers: dict[str, Callable[[Any], Any]] = {}  # key → on_param's function
        self._param_watches: dict[str, Any] = {}  # key → the backend's watch, while created
        self._param_seen: dict[str, Any] = {}  # key → the last value known (set here, or told)

    # -- reading -------------------------------------------------------------------------
    @property
    def name(self) -> str:
        return self._model.name

    @property
    def fullname(self) -> str:
        return planning.node_fullname(self._model)

    @property
    def called(self) -> str:
        """How the user refers to this node, for advice in messages: the variable holding it, else its name."""
        return self.session.call_name(self.dsl)

    @property
    def basenode_name(self) -> Optional[str]:
        """The basenode's full ROS name (``/move_base``), or None for a node that wraps nothing."""
        model = self._model
        return base_fullname(model) if model.base is not None else None

    def model(self) -> NodeModel:
        """A copy of the declared structure, as plain data."""
        with self._lock:
            return copy.deepcopy(self._model)

    def declared_type(self, resolved: str) -> Optional[str]:
        """The type the node declares ``resolved`` with, if it declares it at all."""
        return next((t.type for t in self._model.topics if t.resolved == resolved), None)

    def resolve(self, name: str, kind: str = "topic") -> str:
        """The global name ``name`` has for this node (``~x`` under it, relative names in its namespace)."""
        return names.resolve(name, self._model.namespace, self._model.name, kind, self.session.backend.name_rules)

    def resolve_as(self, role: str, name: str, kind: str) -> str:
        """Resolve a declared name: ``reuse`` names are the basenode's, resolved as it resolves them."""
        return resolve_for(self._model, role, name, kind, self.session.backend.name_rules)

    def handlers(self) -> dict[str, Callable[..., Any]]:
        """The user's function serving each handler slot, by slot key (``"topic /x"``, ``"timer t"``)."""
        with self._lock:
            return dict(self._handlers)

    def param_handlers(self) -> dict[str, Callable[[Any], Any]]:
        """The functions ``on_param`` calls, by parameter key."""
        with self._lock:
            return dict(self._param_handlers)

    def handler(self, name: str) -> Optional[Callable[..., Any]]:
        """The function now serving subscription ``name`` (or the service or timer of that name)."""
        try:
            resolved: Optional[str] = self.resolve(name)
        except TopicNameError:  # not a graph name: only a timer can be called that ("<lambda>")
            resolved = None
        keys = (planning.topic_slot(resolved), planning.service_slot(resolved),
                planning.action_slot(resolved)) if resolved is not None else ()
        for key in (*keys, planning.timer_slot(name)):
            if key in self._handlers:
                return self._handlers[key]
        return None

    def slot(self, key: str) -> Optional[HandlerSlot]:
        """The handler slot ``key`` (``"topic /x"``, ``"timer t"``), if it runs."""
        return self._slots.get(key)

    def slots(self) -> dict[str, HandlerSlot]:
        """Every running handler slot of the node, by key."""
        with self._lock:
            return dict(self._slots)

    def sent(self) -> list[SendFigures]:
        """Per topic the node sends on (publications, relays): messages, subscribers, and drops
        for subscribers that could not keep up."""
        with self._lock:
            return [endpoint.figures() for endpoint in self._live.values() if hasattr(endpoint, "figures")]

    def slot_versions(self, slot: str) -> tuple[list[HandlerVersion], Optional[int]]:
        """Every function slot ``slot`` was given, oldest first, and the number of the one serving now."""
        with self._lock:
            return list(self._versions.get(slot, ())), self._current_version.get(slot)

    def status(self) -> NodeStatus:
        """Per handler: calls, rate, time, exceptions; per topic sent on: messages, subscribers, drops."""
        rows = []
        for key, slot in sorted(self.slots().items()):
            kind, name = key.split(" ", 1)
            f = slot.figures()
            rows.append(StatusRow(kind, name, getattr(slot.handler, "__name__", "?"), f.calls, f.rate_hz,
                                  f.mean_ms, f.max_ms, f.errors))
        for sent in self.sent():
            rows.append(StatusRow(sent.kind, sent.topic, "", sent.messages, connections=sent.connections,
                                  waiting=sent.waiting, dropped=sent.dropped))
        params = ()
        if self.created:
            params = tuple((f"~{key}", repr(self.get_param(key))) for key in self._model.params
                           if self.session.backend.has_param(self.resolve("~" + key, "parameter")))
        return NodeStatus(self.fullname, self.created, tuple(rows), params)

    def history(self) -> History:
        """Every change of this node so far, oldest first."""
        journal = self.session.journal
        return History(self.fullname, tuple(c for c in self.session.history if c.node == self.fullname),
                       journal.path if journal else None)

    # -- changing --------------------------------------------------------------------------
    def apply(self, edit: Callable[[NodeModel], None], change: str) -> None:
        """Edit the model as one change (all or nothing; made live at once if the node runs) and record it."""
        self.change(edit)
        self.record(change)

    def change(self, edit: Callable[[NodeModel], None], handlers: Optional[Handlers] = None,
               drop: tuple[str, ...] | list[str] = (), check: tuple[TopicModel, ...] = ()) -> None:
        """Apply ``edit`` to a copy of the model; if the node runs, reconcile; then commit.

        ``handlers`` gives slots new functions (swapped live, a new version each), ``drop``
        forgets the functions of slots that go, ``check`` are topics whose declared type is
        checked against the live graph. Either everything happens or nothing does: a failure
        while opening endpoints closes what was opened and reopens what was closed.
        """
        with self._lock:
            new_model = copy.deepcopy(self._model)
            edit(new_model)
            if self.created:
                check_wrapping(new_model)  # e.g. a reuse declared on a running node with no basenode
                self._check_live_types(check)
                self._reconcile(new_model, handlers or {})
            for key in drop:
                self._handlers.pop(key, None)
            for key, (handler, _) in (handlers or {}).items():
                if self._handlers.get(key) is not handler:
                    self._add_version(key, handler)
                self._handlers[key] = handler
            self._takes_argument.update({k: takes for k, (_, takes) in (handlers or {}).items()})
            old_model, self._model = self._model, new_model
            self._writers.clear()
            if self.created and self.base is not None:
                self._remap_base(old_model, new_model)

    def _remap_base(self, old: NodeModel, new: NodeModel) -> None:
        """Start the basenode again when what it must be remapped to changed (a ``reuse`` declared or removed on
        the running node): a process's remaps are fixed at its start, so this is the only way; it is said."""
        parts = self.session.backend.action_parts
        if old.base is None or new.base is None or (basenode_remaps(old, parts), base_fullname(old)) == (
                basenode_remaps(new, parts), base_fullname(new)):
            return
        self.session.notify(f"ipyros: restarting basenode {base_fullname(new)} of {self.called} so that it uses "
                            "the names declared since it started (remaps are fixed when a process starts; "
                            "its state starts over)")
        self.base.stop()
        self.base = None
        start_base(self)

    def record(self, change: str) -> None:
        """Add ``change`` to the session's history (with the handler version it made, if any)."""
        pending, self._new_version = self._new_version, None
        if pending is None:
            self.session.record(self.fullname, change)
            return
        slot, version = pending
        if self._reverting is not None:
            change = f"revert {slot} to version {version.number} ({version.name})"
        self.session.record(self.fullname, change, slot=slot, version=version.number, handler=version.name,
                            source=version.source)

    def snapshot(self) -> tuple:
        """What a declaration chain may have to come back to: the model, the handlers and their versions."""
        with self._lock:
            return (copy.deepcopy(self._model), dict(self._handlers), dict(self._takes_argument),
                    {slot: list(found) for slot, found in self._versions.items()}, dict(self._current_version))

    def restore(self, snapshot: tuple, change: str) -> None:
        """Make the node (live, if it runs) what it was at ``snapshot``, as one recorded change."""
        model, handlers, takes, versions, current = snapshot
        with self._lock:
            def edit(new: NodeModel) -> None:
                new.__dict__.update(copy.deepcopy(model).__dict__)

            swapped = {k: (h, takes.get(k, True)) for k, h in handlers.items() if self._handlers.get(k) is not h}
            self.change(edit, swapped, drop=[k for k in self._handlers if k not in handlers])
            self._versions, self._current_version, self._new_version = versions, current, None
            self.record(change)

    # -- the node's life ------------------------------------------------------------------
    def create(self) -> None:
        """Start the node: everything declared so far begins to run; nothing half-started stays if it fails."""
        with self._lock:
            if self.created:
                return
            check_wrapping(self._model, [n._model for n in self.session.nodes.values() if n is not self and n.created])
            session = self.session
            session.add(self)
            try:
                session.start_process_node(self.fullname)
                session.backend.open_host(self.fullname, parameters=bool(self._model.params))
                session.require_graph(f"{self.called}.create()")
                self._check_live_types(self._model.topics)
                self._set_params(self._model.params)
                for key in self._param_handlers:
                    self._watch_param(key)
                self._output = session.output_scope(self.dsl)
                for slot in self._slots.values():  # heard again (quietened by a shutdown)
                    slot.closing = False
                self._open(planning.plan(self._model))
                self.created = True
                start_base(self)
                self.record("create()")
            except KeyboardInterrupt:  # Ctrl-C at the prompt: one line, with everything of the node stopped
                self.shutdown()
                raise interrupted(f"{self.called}.create()", f"{self.called} and its basenode were stopped") from None
            except BaseException:
                self.shutdown()
                raise

    def shutdown(self) -> None:
        """Stop the node's publishers, subscribers, timers, services and its basenode."""
        self.quieten()
        with self._lock:
            if self.created:
                self.record("shutdown()")
            if self.base is not None:
                self.base.stop()
                self.base = None
            for watch in self._param_watches.values():
                watch.close()
            self._param_watches.clear()
            for spec in reversed(list(self._live)):
                try:
                    self._live.pop(spec).close()
                except Exception:  # noqa: BLE001 - closing must go on: a half-closed node is worse
                    pass
            self._writers.clear()
            self.session.backend.close_host(self.fullname)
            self.created = False
            self.session.remove(self)

    def release_base(self) -> Any:
        """Hand the running basenode over to be stopped elsewhere (beside others: ``Session.shutdown_nodes``)."""
        with self._lock:
            base, self.base = self.base, None
            return base

    def quieten(self) -> None:
        """Let the node's handlers fail silently from now on: it is shutting down (its timer's last call may
        find its publisher closed, which is no news). :meth:`create` makes them heard again."""
        for slot in list(self._slots.values()):
            slot.closing = True

    def register_params(self) -> int:
        """Set the node's parameters again (after a ROS 1 master restart); how many."""
        params = self.model().params
        self._set_params(params)
        return len(params)

    # -- writing -------------------------------------------------------------------------------
    def writer(self, topic: str) -> tuple[Any, str]:
        """The publication ``write(topic, ...)`` sends through, and the type declared for it."""
        found = self._writers.get(topic)
        if found is not None:
            return found
        resolved = self.resolve(topic)
        with self._lock:
            target = planning.write_target(self._model, resolved)
            if target is None:
                raise NotDeclaredError(f"{self.name} does not publish {resolved}; declare it first: "
                                       f"{self.called}.new.publish(topic={topic!r}, msgType=...)")
            if not self.created:
                raise NodeStateError(f"{self.name} is not running; call {self.called}.create() before write()")
            declared = self.declared_type(resolved) or ""
            publication = next(ep for spec, ep in self._live.items()
                               if isinstance(spec, planning.PublishSpec) and spec.topic == target)
            self._writers[topic] = (publication, declared)
            return publication, declared

    def write(self, topic: str, msg: Any) -> None:
        """Publish ``msg`` on ``topic`` (see :meth:`rosNode.write <ipyros.dsl.rosnode.rosNode.write>`)."""
        publication, type_name = self.writer(topic)
        got = msgtypes.type_name(msg)  # a class of the right type is refused by the publication, in its words
        if got != type_name:
            got = got or type(msg).__name__
            raise MessageTypeError(f"{topic} carries {type_name}, not {got}; "
                                   f"build a {type_name.split('/')[1]}() and write that")
        publication.write(msg)

    def send_goal(self, name: str, goal: Any, action_type: Any, feedback: Optional[Callable[[Any], None]],
                  timeout: float) -> Any:
        """Send a goal to action ``name`` (see :meth:`rosNode.send_goal <ipyros.dsl.rosnode.rosNode.send_goal>`)."""
        if not self.created:
            raise NodeStateError(f"{self.name} is not running; call {self.called}.create() first")
        return self.session.send_goal(self.resolve(name, "action"), goal, action_type, feedback, timeout)

    # -- parameters (by key, as nd.params takes them) ------------------------------------------
    def get_param(self, key: str) -> Any:
        return self.session.backend.get_param(self.resolve("~" + key, "parameter"))

    def read_param(self, key: str) -> Any:
        """The parameter's value: the live one once created, else the declared one; a KeyError that says which
        parameters there are if it has none of that name."""
        if self.created:
            if not self.session.backend.has_param(self.resolve("~" + key, "parameter")):
                raise self._missing(key)
            return self.get_param(key)
        if key not in self._model.params:
            raise self._missing(key)
        return self._model.params[key]

    def set_param(self, key: str, value: Any) -> None:
        name = self.resolve("~" + key, "parameter")
        backend = self.session.backend
        backend.check_param(name, value)
        with self._lock:
            if self.created:
                self.session.require_graph(f"{self.called}.params[{key!r}] = ...")
                self._param_seen[key] = value  # set here: not news for on_param
                backend.set_param(name, value)
            self._model.params[key] = value
            self.record(f"params[{key!r}] = {value!r}")

    def delete_param(self, key: str) -> None:
        name = self.resolve("~" + key, "parameter")
        backend = self.session.backend
        with self._lock:
            live = self.created and backend.has_param(name)
            if key not in self._model.params and not live:
                raise self._missing(key)
            if live:
                backend.delete_param(name)
            self._model.params.pop(key, None)

    def _missing(self, key: str) -> KeyError:
        """A KeyError, as a mapping raises, that says which parameters there are."""
        have = ", ".join(repr(k) for k in self._model.params) or "none yet"
        return KeyError(f"{self.name} has no parameter {key!r} (it has {have}); "
                        f"set one with {self.called}.params[{key!r}] = value")

    def on_param(self, key: str, handler: Optional[Callable[[Any], Any]]) -> None:
        """Call ``handler(value)`` when someone else sets parameter ``key`` (see :meth:`rosNode.on_param
        <ipyros.dsl.rosnode.rosNode.on_param>`); ``None`` stops it."""
        with self._lock:
            watch = self._param_watches.pop(key, None)
            if watch is not None:
                watch.close()
            if handler is None:
                self._param_handlers.pop(key, None)
                self.record(f"on_param({key!r}, None)")
                return
            if key not in self._model.params:
                raise NotDeclaredError(f"{self.name} has no parameter {key!r} to watch; give it a value first, "
                                       f"{self.called}.params[{key!r}] = ..., then {self.called}.on_param({key!r}, fn)")
            self._param_handlers[key] = handler
            if self.created:
                self._watch_param(key)
            self.record(f"on_param({key!r}, {versions_mod.name_of(handler) or 'handler'})")

    def _watch_param(self, key: str) -> None:
        self._param_seen[key] = self._model.params.get(key)
        name = self.resolve("~" + key, "parameter")
        self._param_watches[key] = self.session.backend.watch_param(name, lambda value: self._param_set(key, value))

    def _param_set(self, key: str, value: Any) -> None:
        """A parameter was set (told by the backend, from whatever thread): the handler runs if it changed."""
        if value == self._param_seen.get(key):  # this session set it, or it was set to what it was
            return
        self._param_seen[key] = value
        handler = self._param_handlers.get(key)
        if handler is None:
            return
        try:
            handler(value)
        except Exception as error:  # noqa: BLE001 - a handler's crash never takes the node down
            self._complain(f"on_param({key!r}) handler {versions_mod.name_of(handler) or ''} raised "
                           f"{type(error).__name__}: {error} (the parameter is {value!r}; the node runs on)")

    def _set_params(self, params: dict[str, Any]) -> None:
        for key, value in params.items():
            self.session.backend.set_param(self.resolve("~" + key, "parameter"), value)

    # -- handler versions -------------------------------------------------------------------
    def find_target(self, name: str) -> HandlerTarget:
        """What ``name`` (a topic, a timer name or a service) is on this node, if it has a handler."""
        model = self.model()
        try:
            resolved: Optional[str] = self.resolve(name)
        except TopicNameError:  # not a graph name: only a timer can be called that
            resolved = None
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
                f"{self.name} relays {resolved} unchanged (reuse), with no handler to edit; to handle it, "
                f"declare one: {self.called}.new.subscribe({relayed.name!r}, handler, msgType={relayed.type!r})")
        known = "; its handlers: " + ", ".join(handlers) if handlers else (
            f"; it has no handlers yet: declare one, e.g. {self.called}.new.subscribe(TOPIC, handler, msgType=...)")
        raise NotDeclaredError(f"{self.name} has no handler for {resolved or name}{known}")

    def relayed_target(self, name: str) -> Optional[HandlerTarget]:
        """``name`` as a topic this node only relays (``reuse``, no handler yet), as a target a handler can take
        over (``%handler`` offers a pass-through to start from); None if it is not one."""
        try:
            resolved = self.resolve(name)
        except TopicNameError:
            return None
        model = self.model()
        relayed = next((t for t in model.topics if t.role == "reuse" and name in (t.name, t.resolved)), None) or \
            next((t for t in model.topics if t.role == "reuse" and t.resolved == resolved), None)
        if relayed is None or model.topic(relayed.resolved, "subscribe", "new") is not None:
            return None
        return HandlerTarget("relay", relayed.name, planning.topic_slot(relayed.resolved))

    def current_handler(self, target: HandlerTarget) -> Callable[..., Any]:
        """The function that serves ``target`` now."""
        handler = self.handler(target.name)
        if handler is None:  # the node changed since find_target
            raise NotDeclaredError(f"{self.name} has no handler for {target.label} any more")
        return handler

    def redeclare(self, target: HandlerTarget, handler: Callable[..., Any]) -> None:
        """Declare ``target`` again exactly as it is, but served by ``handler`` (a live swap, as the DSL does it)."""
        model, dsl = self.model(), self.dsl
        if target.kind == "relay":  # a relayed topic taken over: new.subscribe spelled as its reuse intercepts it
            relayed = next((t for t in model.topics if t.role == "reuse" and t.name == target.name), None)
            if relayed is None:
                raise NotDeclaredError(f"{self.name} no longer relays {target.name}")
            dsl.new.subscribe(relayed.name, handler=handler, msgType=relayed.type)
        elif target.kind == "topic":
            topic = model.topic(self.resolve(target.name), "subscribe", "new")
            if topic is None:
                raise NotDeclaredError(f"{self.name} no longer subscribes to {target.name}")
            dsl.new.subscribe(topic.name, handler=handler, msgType=topic.type, qos=topic.qos)
        elif target.kind == "timer":
            timer = model.timer(target.name)
            if timer is None:
                raise NotDeclaredError(f"{self.name} no longer has the timer {target.name}")
            dsl.timer(timer.period, handler, name=timer.name, oneshot=timer.oneshot)
        elif target.kind == "action":
            action = model.action(self.resolve(target.name, "action"), "new")
            if action is None:
                raise NotDeclaredError(f"{self.name} no longer serves the action {target.name}")
            dsl.new.action(action.name, action.type, handler=handler)
        else:
            resolved = self.resolve(target.name, "service")
            service = next((s for s in model.services if s.resolved == resolved and s.role == "new"), None)
            if service is None:
                raise NotDeclaredError(f"{self.name} no longer serves {target.name}")
            dsl.new.service(service.name, srvType=service.type, handler=handler)

    def versions(self, what: str) -> Versions:
        target = self.find_target(what)
        with self._lock:
            return Versions(f"{self.name} {target.label}", tuple(self._versions.get(target.slot, ())),
                            self._current_version.get(target.slot))

    def revert(self, what: str, version: int) -> None:
        target = self.find_target(what)
        with self._lock:
            known = self._versions.get(target.slot, [])
            if isinstance(version, bool) or not isinstance(version, int) or not 1 <= version <= len(known):
                raise NotDeclaredError(f"{self.name} {target.label} has versions 1 to {len(known)}, not {version!r}; "
                                       f"{self.called}.versions({what!r}) lists them")
            chosen = known[version - 1]
            if chosen.function is None:
                namespace = getattr(self.current_handler(target), "__globals__", {})
                chosen.function = versions_mod.compile_version(chosen, namespace, f"{self.name} {target.label}")
            self._reverting = version
            try:
                self.redeclare(target, chosen.function)
            finally:
                self._reverting = None

    def restore_versions(self, what: str, versions: list[tuple[str, str]], current: Optional[int]) -> None:
        target = self.find_target(what)
        current = len(versions) if current is None else current
        if not versions or isinstance(current, bool) or not isinstance(current, int) \
                or not 1 <= current <= len(versions):
            raise DeclarationError(f"restore_versions({what!r}): current={current!r} is not one of the "
                                   f"{len(versions)} versions given")
        restored = []
        for number, entry in enumerate(versions, 1):
            if not (isinstance(entry, (tuple, list)) and len(entry) == 2 and isinstance(entry[1], str)
                    and entry[1].strip()):
                raise DeclarationError(f"restore_versions({what!r}): version {number} is not (time, source text)")
            when, source = entry
            restored.append(HandlerVersion(number, versions_mod.parse_time(when), versions_mod.defined_name(source),
                                           source))
        with self._lock:
            restored[current - 1].function = self.current_handler(target)
            self._versions[target.slot] = restored
            self._current_version[target.slot] = current

    def _add_version(self, slot: str, handler: Callable[..., Any]) -> None:
        """Note that ``slot`` is now served by ``handler``: a new version, or an old one brought back."""
        versions = self._versions.setdefault(slot, [])
        if self._reverting is not None:
            version = versions[self._reverting - 1]
        else:
            version = HandlerVersion(len(versions) + 1, time.time(), versions_mod.name_of(handler) or "handler",
                                     versions_mod.source_of(handler), handler)
            versions.append(version)
        self._current_version[slot] = version.number
        self._new_version = (slot, version)

    # -- reconciling the live node with the model ----------------------------------------------
    def _reconcile(self, new_model: NodeModel, handlers: Handlers) -> None:
        old = planning.plan(self._model)
        new = planning.plan(new_model)
        removed = [s for s in old if s not in new]
        added = [s for s in new if s not in old]
        if added:
            self.session.require_graph(f"opening {', '.join(_describe(s) for s in added)} on {self.name}")
        # Swap first: a slot that stays keeps its subscription, so no message is lost.
        for key, (handler, takes) in handlers.items():
            if key in self._slots:
                self._slots[key].swap(handler, takes)
        closed = []
        for spec in removed:  # before opening: a topic whose type changed must be freed first
            self._live.pop(spec).close()
            closed.append(spec)
        pending = dict(self._handlers)
        pending.update({k: h for k, (h, _) in handlers.items()})
        takes_arg = dict(self._takes_argument)
        takes_arg.update({k: t for k, (_, t) in handlers.items()})
        try:
            self._open(added, pending, takes_arg)
        except BaseException:
            for spec in added:
                endpoint = self._live.pop(spec, None)
                if endpoint is not None:
                    endpoint.close()
            self._open(closed)
            raise
        still_used = {getattr(s, "slot", None) for s in new}
        for key in list(self._slots):
            if key not in still_used:
                del self._slots[key]

    def _open(self, specs: Any, handlers: Optional[dict[str, Callable[..., Any]]] = None,
              takes_arg: Optional[dict[str, bool]] = None) -> None:
        handlers = self._handlers if handlers is None else handlers
        takes_arg = self._takes_argument if takes_arg is None else takes_arg
        learn_relayed_types(self, [s for s in specs if isinstance(s, planning.RelaySpec)])
        for spec in specs:
            try:
                self._live[spec] = self._open_one(spec, handlers, takes_arg)
            except IpyrosError:
                raise
            except Exception as error:  # the client library's own complaint, made one line
                raise DeclarationError(f"cannot open {type(spec).__name__[:-4].lower()} "
                                       f"{getattr(spec, 'topic', None) or getattr(spec, 'name', '')}: "
                                       f"{first_line(error)}") from None

    def _open_one(self, spec: Spec, handlers: dict[str, Callable[..., Any]], takes_arg: dict[str, bool]) -> Any:
        backend, host = self.session.backend, self.fullname
        if isinstance(spec, planning.PublishSpec):
            qos = replace(spec.qos, durability="transient_local") if spec.latch else spec.qos
            return backend.publication(host, spec.topic, msgtypes.resolve_message(spec.type)[1], qos, self._complain,
                                       spec.follows)
        if isinstance(spec, planning.RelaySpec):
            def wrong_type(got: str, spec: planning.RelaySpec = spec) -> None:
                self.session.notify(f"ipyros: {spec.source} carries {got}, but {self.name} relays it as {spec.type}; "
                                    f"messages are dropped: declare type={got!r}")

            try:
                cls = msgtypes.resolve_message(spec.type)[1]
            except MessageTypeError:
                if not backend.relays_any_type:
                    raise
                return backend.raw_relay(host, spec.source, spec.target, spec.type, wrong_type, self._complain)
            return backend.relay(host, spec.source, spec.target, cls, wrong_type, self._complain)
        if isinstance(spec, planning.ServiceRelaySpec):
            return backend.service_relay(host, spec.source, spec.target, msgtypes.resolve_service(spec.type)[1],
                                         self._complain)
        if isinstance(spec, planning.ActionRelaySpec):
            def wrong_part(got: str, spec: planning.ActionRelaySpec = spec) -> None:
                self.session.notify(f"ipyros: a part of action {spec.source} carries {got}, but {self.name} relays "
                                    f"it as {spec.type}; its messages are dropped: declare the action's own type")

            return backend.action_relay(host, spec.source, spec.target, msgtypes.resolve_action(spec.type)[1],
                                        wrong_part, self._complain)
        slot = self._slots.get(spec.slot)
        if slot is None:
            label = f"{self.name} {spec.slot.split(' ', 1)[1]}"
            slot = HandlerSlot(label, handlers[spec.slot], self.session.report,
                               pass_argument=takes_arg.get(spec.slot, True), keep=self.session.config.keep_recent,
                               output=self._output)
            self._slots[spec.slot] = slot
        if isinstance(spec, planning.SubscribeSpec):
            return backend.subscription(host, spec.topic, msgtypes.resolve_message(spec.type)[1], slot, spec.qos,
                                        self._complain)
        if isinstance(spec, planning.TimerSpec):
            return backend.timer(host, spec.period, slot, spec.oneshot, self._complain)
        if isinstance(spec, planning.ActionServerSpec):
            return backend.action_server(host, spec.name, msgtypes.resolve_action(spec.type)[1], slot, spec.forward)
        return backend.service(host, spec.name, msgtypes.resolve_service(spec.type)[1], slot)

    def _complain(self, text: str) -> None:
        """What the backend finds wrong with a live endpoint of this node, told at the prompt."""
        self.session.notify(f"ipyros: {self.name}: {text}")

    def _check_live_types(self, topics: Any) -> None:
        """Refuse a declared type that differs from the type a live topic already has.

        The backend says what the graph holds (ROS 1's master remembers a topic's type after
        everyone left it, so only topics with a publisher or subscriber count; ROS 2 matches
        nothing between two types and says nothing, so there the type watch tells of it
        later). Topics only this session uses are checked against its other nodes (this node
        may change its own topic's type).
        """
        if not topics:
            return
        live = self.session.backend.live_types([t.resolved for t in topics])
        for t in topics:
            have, ours_only = live.get(t.resolved, (None, False))
            if not have or have == t.type or have == "*":
                continue
            if ours_only:
                have = next((o.type for n in self.session.nodes.values() if n is not self
                             for o in n._model.topics if o.resolved == t.resolved and o.type != t.type), None)
                if have is None:
                    continue
            raise TopicTypeConflict(f"{t.resolved} already carries {have}, not {t.type}; "
                                    f"declare msgType={have!r} or use another topic name")


def _describe(spec: Spec) -> str:
    """``publisher /x``, ``relay /a -> /b``: an endpoint of the plan in a few words."""
    kind = {"PublishSpec": "publisher", "SubscribeSpec": "subscriber", "ServiceRelaySpec": "service relay",
            "ActionServerSpec": "action server", "ActionRelaySpec": "action relay"}.get(
        type(spec).__name__, type(spec).__name__.removesuffix("Spec").lower())
    if isinstance(spec, (planning.RelaySpec, planning.ServiceRelaySpec, planning.ActionRelaySpec)):
        return f"{kind} {spec.source} -> {spec.target}"
    return f"{kind} {getattr(spec, 'topic', None) or getattr(spec, 'name', '')}"
