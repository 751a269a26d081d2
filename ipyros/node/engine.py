"""What makes a DSL node live: its model, its handler slots, its open endpoints, and the one change that moves them.

A :class:`~ipyros.dsl.rosnode.rosNode` is the user's DSL and nothing else (``nd.<TAB>`` shows
the paper's methods); each one owns a :class:`NodeEngine`, which holds its state and is the
one place where the model and the running node change: :meth:`NodeEngine.change` edits a
copy of the model, and if the node runs, reconciles the live endpoints with the plan of
the new model (:mod:`ipyros.core.plan`) through the session's backend, then commits. A
rejected change leaves model and running node as they were.

Its other concerns are parts of their own: declaring (:mod:`.declaring`: every checked edit,
whoever makes it), opening an endpoint (:mod:`.endpoints`), handler versions (:mod:`.versions`),
parameters and ``on_param`` (:mod:`.params`), what a name is on the node and its handler's versions
(:mod:`.handlers`, over :mod:`.targets`).
ipyros's own modules (wrapping, saving and exporting, the tools and the magics) use a node
through its engine (:func:`ipyros.dsl.engine_of`), never through private fields.
"""

from __future__ import annotations

import copy
import threading
from typing import Any, Callable, Optional

from ..core import names, plan as planning
from ..core.errors import NodeStateError, NotDeclaredError, TopicTypeConflict
from ..core.guard import ESTOP_TYPE
from ..core.model import NodeModel, TopicModel
from ..core.plan import Spec
from ..core.records import History, NodeStatus, StatusRow
from ..core.remapping import base_fullname, basenode_remaps, check_wrapping, resolve_for
from ..core.slots import HandlerSlot, OutputScope, SendFigures
from ..core.versions import HandlerVersion
from ..processes.basenode import BaseHandle
from . import declaring
from .endpoints import Opening, describe, open_endpoint, output_of
from .guards import NodeGuards, guard_of
from .handlers import HandlerEdits
from .params import NodeParameters
from .placedrelay import PlacedRelay, PlacedRelays, PlacedSpec
from .session import Session
from .targets import HandlerTarget, handler_slots
from .versions import HandlerVersions
from .writing import Writing
from .baseinterface import learn_relayed_types
from .basestart import start_bag_clock, start_base, stop_bag_clock
from .wrapping import interrupted

#: A slot key's new handler and whether it takes the message (or timer event) as its argument.
Handlers = dict[str, tuple[Callable[..., Any], bool]]

__all__ = ["HandlerTarget", "NodeEngine"]



class NodeEngine:
    """The state of one DSL node and the changes to it; see the module's docstring."""

    def __init__(self, owner: object, model: NodeModel, session: Session, explicit_namespace: bool) -> None:
        #: What the user holds for this node (its rosNode), kept for identity alone: advice finds the variable that
        #: holds it, the DSL hands it back (``ipyros.dsl.node_of``). Nothing below the DSL calls it.
        self.owner = owner
        self.session = session
        #: Whether the namespace was given; a wrapping node without one lives in its basenode's.
        self.explicit_namespace = explicit_namespace
        self.created = False
        #: The running basenode (a process, or a launch file's rest and node), for wrapping nodes.
        self.base: Optional[BaseHandle] = None  # its basenode, here or on a machine
        self._placed_relays: Optional[PlacedRelays] = None  # its relays that run beside a basenode placed on a machine
        self._model = model
        self._handlers: dict[str, Callable[..., Any]] = {}  # slot key → the user's function
        self._takes_argument: dict[str, bool] = {}  # slot key → call the handler with the message/event?
        self._slots: dict[str, HandlerSlot] = {}
        self._output: Optional[OutputScope] = None  # where its handlers print (the creating cell, in Jupyter)
        self._live: dict[Spec, Any] = {}  # spec → runtime endpoint
        self._versions = HandlerVersions()
        self._lock = threading.RLock()
        #: Its own parameters and on_param's functions (``nd.params`` spells them).
        self.params = NodeParameters(self, self._lock)
        #: What it sends by hand: write, a message on a guarded output, goals.
        self.writing = Writing(self)
        #: What a name is on it, the function serving it, and its versions (%handler, %edit, nd.revert).
        self.handlers_of = HandlerEdits(self, self._versions, self._lock)
        #: Its guards, while it runs.
        self.guards = NodeGuards(session.backend, lambda text: session.notify(f"ipyros: {text}"), session.guard_watch,
                                 self.writing.send)

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
        return self.session.call_name(self.owner)

    @property
    def basenode_name(self) -> Optional[str]:
        """The basenode's full ROS name (``/move_base``), or None for a node that wraps nothing."""
        model = self._model
        return base_fullname(model) if model.base is not None else None

    def model(self) -> NodeModel:
        """A copy of the declared structure, as plain data."""
        with self._lock:
            return copy.deepcopy(self._model)

    def declared(self) -> NodeModel:
        """The declared structure as it stands, not a copy: for reading alone (what the session's other nodes
        check a new one against: a copy of each at every create() was quadratic in the session's nodes)."""
        return self._model

    def declared_params(self) -> dict[str, Any]:
        """The model's own parameters (edited in place by :attr:`params`, under the node's lock)."""
        return self._model.params

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
        return self.params.handlers()

    def handler(self, name: str) -> Optional[Callable[..., Any]]:
        """The function now serving subscription ``name`` (or the service, action or timer of that name)."""
        return next((self._handlers[key] for key in handler_slots(self.resolve, name) if key in self._handlers), None)

    def live(self) -> dict[Spec, Any]:
        """Its open endpoints, by the plan's spec (a copy)."""
        with self._lock:
            return dict(self._live)

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
            found = (endpoint.figures() for endpoint in self._live.values() if hasattr(endpoint, "figures"))
            return [figures for figures in found if figures is not None]  # None: a placed service's relay

    def slot_versions(self, slot: str) -> tuple[list[HandlerVersion], Optional[int]]:
        """Every function slot ``slot`` was given, oldest first, and the number of the one serving now."""
        with self._lock:
            return self._versions.of(slot)

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
        return NodeStatus(self.fullname, self.created, tuple(rows), self.params.live() if self.created else (),
                          self.guards.states())

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
                check_live_types(self, check)
                before = {(g.resolved, g.estop_topic) for g in self._model.guards}
                check_estop_topics(self, [g for g in new_model.guards if (g.resolved, g.estop_topic) not in before])
                self._reconcile(new_model, handlers or {})
            for key in drop:
                self._handlers.pop(key, None)
            for key, (handler, _) in (handlers or {}).items():
                if self._handlers.get(key) is not handler:
                    self._versions.given(key, handler)
                self._handlers[key] = handler
            self._takes_argument.update({k: takes for k, (_, takes) in (handlers or {}).items()})
            old_model, self._model = self._model, new_model
            self.writing.forget()
            if self.created:
                self.guards.update(new_model.guards)
                if self.base is not None:
                    self._remap_base(old_model, new_model)

    def _remap_base(self, old: NodeModel, new: NodeModel) -> None:
        """Start the basenode again when what it must be remapped to changed (a ``reuse`` declared or removed on
        the running node): a process's remaps are fixed at its start, so this is the only way; it is said."""
        parts = self.session.backend.action_parts
        if self.base is None or old.base is None or new.base is None or (
                basenode_remaps(old, parts), base_fullname(old)) == (
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
        pending = self._versions.take_pending()
        if pending is None:
            self.session.record(self.fullname, change)
            return
        slot, version = pending
        if self._versions.reverting is not None:
            change = f"revert {slot} to version {version.number} ({version.name})"
        self.session.record(self.fullname, change, slot=slot, version=version.number, handler=version.name,
                            source=version.source)

    def snapshot(self) -> tuple:
        """What a declaration chain may have to come back to: the model, the handlers and their versions."""
        with self._lock:
            return (copy.deepcopy(self._model), dict(self._handlers), dict(self._takes_argument),
                    self._versions.snapshot())

    def restore(self, snapshot: tuple, change: str) -> None:
        """Make the node (live, if it runs) what it was at ``snapshot``, as one recorded change."""
        model, handlers, takes, versions = snapshot
        with self._lock:
            def edit(new: NodeModel) -> None:
                new.__dict__.update(copy.deepcopy(model).__dict__)

            swapped = {k: (h, takes.get(k, True)) for k, h in handlers.items() if self._handlers.get(k) is not h}
            self.change(edit, swapped, drop=[k for k in self._handlers if k not in handlers])
            self._versions.restore(versions)
            self.record(change)

    # -- the node's life ------------------------------------------------------------------
    def create(self) -> None:
        """Start the node: everything declared so far begins to run; nothing half-started stays if it fails."""
        with self._lock:
            if self.created:
                return
            running = [n.declared() for n in self.session.nodes.values() if n is not self and n.created]
            check_wrapping(self._model, running)
            session = self.session
            session.add(self)
            try:
                session.start_process_node(self.fullname)
                session.backend.open_host(self.fullname, parameters=bool(self._model.params), complain=self.complain)
                session.require_graph(f"{self.called}.create()")
                check_live_types(self, self._model.topics)
                check_estop_topics(self, self._model.guards)
                self.params.start()
                self._output = session.output_scope(self.owner)
                for slot in self._slots.values():  # heard again (quietened by a shutdown)
                    slot.closing = False
                self.guards.ending = False
                self._open(planning.plan(self._model), self._model)
                self.created = True
                start_bag_clock(self)
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
            stop_bag_clock(self)
            self.params.stop()
            for spec in reversed(list(self._live)):
                try:
                    self._live.pop(spec).close()
                except Exception:  # noqa: BLE001 - closing must go on: a half-closed node is worse
                    pass
            self.writing.forget()
            self.session.backend.close_host(self.fullname)
            self.created = False
            self.session.remove(self)

    def now(self) -> float:
        """The node's ROS time (s): a bag's time while the session runs on its clock."""
        if not self.created:
            raise NodeStateError(f"{self.name} is not running; call {self.called}.create() first")
        return self.session.backend.now(self.fullname)

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
        self.guards.quieten()

    def register_params(self) -> int:
        """Set the node's parameters again (after a ROS 1 master restart); how many."""
        return self.params.set_all()

    # -- guards: e-stop --------------------------------------------------------------------------
    def estop(self, on: bool) -> list[str]:
        """Hold every guarded output of the node at its stop message (``on``), sent at once; or release it."""
        with self._lock:
            if not self._model.guards:
                raise NotDeclaredError(f"{self.name} has no guard to {'e-stop' if on else 'release'}; guard an "
                                       f"output first: {self.called}.guard(TOPIC, limits=..., timeout=...)")
            if not self.created:
                raise NodeStateError(f"nothing was {'e-stopped' if on else 'released'}: {self.name} is not running, so "
                                     f"it sends nothing; its guards stand from {self.called}.create() on")
            topics = self.guards.estop(on)
            for topic in topics if on else ():
                self.writing.send(topic, self.guards.live[topic].stop_message())
            self.record("estop()" if on else "release()")
            return topics

    # -- reconciling the live node with the model ----------------------------------------------
    def _reconcile(self, new_model: NodeModel, handlers: Handlers) -> None:
        old = planning.plan(self._model)
        new = planning.plan(new_model)
        removed = [s for s in old if s not in new]
        added = [s for s in new if s not in old]
        if added:
            self.session.require_graph(f"opening {', '.join(describe(s) for s in added)} on {self.name}")
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
            self._open(added, new_model, pending, takes_arg)
        except BaseException:
            for spec in added:
                endpoint = self._live.pop(spec, None)
                if endpoint is not None:
                    endpoint.close()
            self._open(closed, self._model)
            raise
        self.guards.attach(self._live, output_of)  # a guard added or removed: its running output knows
        still_used = {getattr(s, "slot", None) for s in new}
        for key in list(self._slots):
            if key not in still_used:
                del self._slots[key]

    def _open(self, specs: Any, model: NodeModel, handlers: Optional[dict[str, Callable[..., Any]]] = None,
              takes_arg: Optional[dict[str, bool]] = None) -> None:
        handlers = self._handlers if handlers is None else handlers
        takes_arg = self._takes_argument if takes_arg is None else takes_arg
        learn_relayed_types(self, [s for s in specs if isinstance(s, planning.RelaySpec) and s.machine is None])

        def slot(spec: Any) -> HandlerSlot:
            found = self._slots.get(spec.slot)
            if found is None:
                found = self._slots[spec.slot] = HandlerSlot(
                    f"{self.name} {spec.slot.split(' ', 1)[1]}", handlers[spec.slot], self.session.report,
                    pass_argument=takes_arg.get(spec.slot, True), keep=self.session.config.keep_recent,
                    output=self._output)
            return found

        def guard(spec: Any) -> Any:
            declared, output = model.guard(spec.topic), guard_of(model.outputs(), spec.topic)
            assert declared is not None and output is not None  # the plan lists a guard only on an output
            return self.guards.open(declared, output, self.fullname)

        def placed(spec: PlacedSpec) -> PlacedRelay:
            relays = self._placed_relays
            if relays is None or relays.machine != spec.machine:
                assert model.base is not None and spec.machine is not None  # the plan places a basenode's relays
                relays = self._placed_relays = PlacedRelays(self.session.backend, self.fullname, spec.machine,
                                                            model.base.machine_grace,
                                                            lambda text: self.session.notify(f"ipyros: {text}"))
            return relays.open(spec)

        at = Opening(self.session.backend, self.fullname, self.name, self.complain, self.session.notify, slot,
                     self.guards.gate, guard, placed)
        for spec in specs:
            self._live[spec] = open_endpoint(at, spec)

    def complain(self, text: str) -> None:
        """What the backend finds wrong with a live endpoint of this node, told at the prompt."""
        self.session.notify(f"ipyros: {self.name}: {text}")


def check_live_types(engine: NodeEngine, topics: Any) -> None:
    """Refuse a type ``engine`` declares that differs from the type a live topic already has.

    The backend says what the graph holds (ROS 1's master remembers a topic's type after
    everyone left it, so only topics with a publisher or subscriber count; ROS 2 matches
    nothing between two types and says nothing, so there the type watch tells of it
    later). Topics only this session uses are checked against its other nodes (a node
    may change its own topic's type).
    """
    if not topics:
        return
    session = engine.session
    live = session.backend.live_types([t.resolved for t in topics])
    for t in topics:
        have, ours_only = live.get(t.resolved, (None, False))
        if not have or have == t.type or have == "*":
            continue
        if ours_only:
            have = next((o.type for n in session.nodes.values() if n is not engine
                         for o in n.declared().topics if o.resolved == t.resolved and o.type != t.type), None)
            if have is None:
                continue
        raise TopicTypeConflict(f"{t.resolved} already carries {have}, not {t.type}; "
                                f"declare msgType={have!r} or use another topic name")


def check_estop_topics(engine: NodeEngine, guards: Any) -> None:
    """Refuse an e-stop topic that carries another type than ``std_msgs/Bool`` in the live graph: its guard's process
    would never hear a press there (ROS 1 connects nothing, ROS 2 matches nothing). Read from the graph on both ROS
    (ROS 2's declarations are not checked against it otherwise: DDS keeps a type per endpoint)."""
    wanted = [g.estop_topic for g in guards if g.estop_topic]
    if not wanted:
        return
    topics = engine.session.backend.graph_snapshot().topics
    for topic in wanted:
        have = topics.get(topic, "")
        if have and have != ESTOP_TYPE:
            raise TopicTypeConflict(f"{topic} already carries {have}, not {ESTOP_TYPE}; an e-stop topic is a "
                                    f"{ESTOP_TYPE} of its own: give estop_topic another name")
