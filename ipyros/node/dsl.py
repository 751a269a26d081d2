"""The paper's internal DSL: ``rosNode``, ``new``/``reuse``, ``subscribe``, ``publish``, ``create``, ``write``.

Each call validates its input, edits the node's :class:`~ipyros.core.model.NodeModel`, and,
once the node runs, makes the live node match at once (:mod:`ipyros.core.plan` says which
endpoints must exist; the session's backend, :mod:`ipyros.node.backend`, opens and closes them). A rejected
declaration raises a one-line error and changes nothing, neither model nor running node.

    nd = rosNode("turtle_control_node")
    (nd.new.subscribe(topic="/turtle1/pose", handler=showPose, msgType=Pose)
           .publish(topic="/turtle1/cmd_vel", msgType=Twist))
    nd.create()
    nd.write("/turtle1/cmd_vel", msg)
"""

from __future__ import annotations

import contextlib
import copy
import os
import re
import threading
import time
import weakref
from collections.abc import MutableMapping
from dataclasses import replace
from pathlib import Path
from typing import Any, Callable, Iterator, Optional

from ..core import msgtypes, names, plan as planning, qos as qos_mod, versions as versions_mod
from ..core.errors import (DeclarationError, HandlerError, IpyrosError, MessageTypeError, NodeStateError,
                           NotDeclaredError, TopicNameError, TopicTypeConflict, cut, first_line)
from ..core.model import NodeModel, ServiceModel, TimerModel, TopicModel
from ..core.plan import Spec
from ..core.slots import HandlerSlot, OutputScope, call_arity
from ..core.versions import HandlerVersion
from .session import Session, current
from .wrapping import check_reuse, check_wrapping

_UNSET: Any = object()
MIN_TIMER_PERIOD = 1e-4  # seconds; below it a timer would only spin a core (and rospy divides by it)


class rosNode:  # noqa: N801 - the paper's name
    """A ROS node declared, created and reshaped from the prompt.

    ``namespace`` defaults to ``ROS_NAMESPACE`` (or ``/``). Several rosNodes can live in
    one session: they share the process's single rospy node (see the README).
    """

    def __init__(self, name: str = _UNSET, namespace: Optional[str] = None, *, session: Optional[Session] = None,
                 **unknown: Any) -> None:
        if name is _UNSET or unknown:
            given = f"got unknown keyword argument(s) {', '.join(sorted(unknown))}; it" if unknown else "needs a name:"
            raise TypeError(f"rosNode() {given} takes name and namespace, e.g. rosNode('turtle_control_node') "
                            "or rosNode('planner', namespace='/robot1')")
        self._session = session or current()
        # A wrapping node without a namespace of its own lives in its basenode's (see wrap.set_base).
        self._explicit_namespace = namespace is not None
        ns = names.default_namespace() if namespace is None else names.check_namespace(namespace)
        self._model = NodeModel(name=names.check_node_name(name), namespace=ns)
        self._handlers: dict[str, Callable[..., Any]] = {}  # slot key → the user's function
        self._takes_argument: dict[str, bool] = {}  # slot key → call the handler with the message/event?
        self._slots: dict[str, HandlerSlot] = {}
        self._output: Optional[OutputScope] = None  # where its handlers print (the creating cell, in Jupyter)
        self._live: dict[Spec, Any] = {}  # spec → runtime endpoint
        self._writers: dict[str, tuple[Any, str]] = {}  # topic as typed → (publication, type)
        self._versions: dict[str, list[HandlerVersion]] = {}  # slot key → every function it was given
        self._current_version: dict[str, int] = {}  # slot key → number of the version serving it
        self._reverting: Optional[int] = None  # set while revert() re-declares an old version
        self._new_version: Optional[tuple[str, HandlerVersion]] = None  # for the next _record
        self._lock = threading.RLock()
        self._base: Any = None  # the basenode process, for wrapping nodes
        self.created = False
        self.new = TopicHandler(self, "new")
        self.reuse = TopicHandler(self, "reuse")
        self.params = NodeParams(self)

    # -- identity ---------------------------------------------------------------------
    @property
    def name(self) -> str:
        return self._model.name

    @property
    def fullname(self) -> str:
        return planning.node_fullname(self._model)

    @property
    def ros_name(self) -> Optional[str]:
        """The ROS node that hosts this node's endpoints (shared by the session's nodes)."""
        return self._session.process.name if self.created else None

    def model(self) -> NodeModel:
        """A copy of the declared structure, as plain data."""
        with self._lock:
            return copy.deepcopy(self._model)

    def handler(self, topic: str) -> Optional[Callable[..., Any]]:
        """The function now serving subscription ``topic`` (or service / timer name)."""
        try:
            resolved: Optional[str] = self._resolve(topic, "topic")
        except TopicNameError:  # not a graph name: only a timer can be called that ("<lambda>")
            resolved = None
        keys = (planning.topic_slot(resolved), planning.service_slot(resolved)) if resolved is not None else ()
        for key in (*keys, planning.timer_slot(topic)):
            if key in self._handlers:
                return self._handlers[key]
        return None

    def resolve(self, name: str) -> str:
        """The global name ``name`` has for this node."""
        return self._resolve(name, "topic")

    # -- the surface the rest of ipyros uses (wrap, keep, savefile, export) --------------
    @property
    def session(self) -> Session:
        """The session this node lives in (its master, its process node, where notices go)."""
        return self._session

    @property
    def explicit_namespace(self) -> bool:
        """Whether the namespace was given; a wrapping node without one lives in its basenode's."""
        return self._explicit_namespace

    def handlers(self) -> dict[str, Callable[..., Any]]:
        """The user's function serving each handler slot, by slot key (``"topic /x"``, ``"timer t"``)."""
        with self._lock:
            return dict(self._handlers)

    def slot_versions(self, slot: str) -> tuple[list[HandlerVersion], Optional[int]]:
        """Every function slot ``slot`` was given, oldest first, and the number of the one serving now."""
        with self._lock:
            return list(self._versions.get(slot, ())), self._current_version.get(slot)

    def apply(self, edit: Callable[[NodeModel], None], change: str) -> "rosNode":
        """Edit the model as one change (all or nothing; made live at once if the node runs) and record it."""
        self._change(edit)
        self._record(change)
        return self

    def _resolve(self, name: str, kind: str) -> str:
        return names.resolve(name, self._model.namespace, self._model.name, kind)

    def _resolve_as(self, role: str, name: str, kind: str) -> str:
        """Resolve a declared name: ``reuse`` names are the basenode's, resolved as it resolves them."""
        from .wrapping import resolve_for

        return resolve_for(self._model, role, name, kind)

    # -- the basenode ----------------------------------------------------------------
    def baseNode(self, executable: str, **options: Any) -> "rosNode":  # noqa: N802 - the paper's name
        """Wrap the basenode run by ``executable`` (its package is given by :meth:`basePackage`).

        Options: ``name`` (node name, default the executable's), ``namespace``, ``remaps``
        (dict), ``params`` (private parameters), ``args`` (list of arguments).
        """
        from .wrapping import set_base

        return set_base(self, executable=executable, **options)

    def basePackage(self, package: str) -> "rosNode":  # noqa: N802 - the paper's name
        """The package of the basenode, found as rosrun finds it."""
        from .wrapping import set_base

        return set_base(self, package=package)

    def baseLaunch(self, launch: str, node: str, args: Optional[dict[str, Any]] = None,
                   **arg_values: Any) -> "rosNode":  # noqa: N802 - named like baseNode
        """Wrap the node ``node`` that the launch file ``launch`` starts (``/robot1/planner``).

        The file's ``<arg>`` values are given as keywords (``rate=5``) or, for names that
        are not Python identifiers, as ``args={"use-sim": True}``, like
        ``roslaunch FILE rate:=5``. Its package, executable, name, namespace, remaps,
        params and args come from the launch file; ``create()`` runs the rest of the launch
        file untouched, and this node wrapped where it was. The file itself is not edited.
        """
        from .wrapping import set_launch_base

        if args is not None and not isinstance(args, dict):
            raise DeclarationError(f"baseLaunch(args={args!r}): give a dict of the launch file's args, "
                                   "e.g. args={'rate': 5}")
        if not self._session.backend.has_master:
            raise DeclarationError(f"baseLaunch reads ROS 1 launch files, and this session runs ROS 2; give the "
                                   f"node itself: {self.called}.baseNode('/path/to/node', namespace=..., params=...)")
        return set_launch_base(self, launch, node, {**(args or {}), **arg_values})

    def baseBag(self, path: Any, rate: float = 1.0, loop: bool = False, topics: Optional[list[str]] = None,
                delay: float = 5.0) -> "rosNode":  # noqa: N802 - named like baseNode
        """Wrap a recorded bag as the basenode: a bag player (like ``rosbag play``) publishes its
        topics, remapped like any basenode's, so that ``reuse`` and ``new.subscribe`` work on
        recorded data as on a live node, and ``nd.base.restart()`` plays it again (after a
        handler change: the same messages, new behaviour).

        ``rate`` scales the playing speed, ``loop`` plays it again and again, ``topics`` plays
        only these; the player waits until each topic has a subscriber, ``delay`` seconds at most.
        """
        from ..tools.record import bag_module
        from .wrapping import set_base

        if not isinstance(path, (str, os.PathLike)):
            raise DeclarationError(f"baseBag({cut(path)}): give the bag's path, e.g. baseBag('run1.bag')")
        bagfile = bag_module()
        bag = Path(path).expanduser().absolute()
        if not bag.exists():
            raise DeclarationError(f"baseBag({str(path)!r}): no such file; record one with %record FILE TOPIC ...")
        recorded = bagfile.bag_topics(bag)
        missing = sorted(set(topics or ()) - set(recorded))
        if missing:
            raise DeclarationError(f"the bag {bag.name} has no topic {', '.join(missing)}; it has "
                                   f"{', '.join(sorted(recorded)) or 'none'}")
        if not (isinstance(rate, (int, float)) and 0 < rate <= 1000 and 0 <= delay <= 60):
            raise DeclarationError(f"baseBag(rate={rate!r}, delay={delay!r}): rate a speed factor above 0 "
                                   "(1.0 as recorded), delay seconds from 0 to 60")
        return set_base(self, executable=str(bagfile.PLAYER), name="bag_player",
                        args=bagfile.player_args(bag, float(rate), bool(loop), topics, float(delay)))

    def discover(self, timeout: float = 10.0) -> Any:
        """Run the basenode once, read its topics and services from the master, reuse them all.

        Returns the discovered interface (it displays as a table).
        """
        from .wrapping import discover

        return discover(self, timeout)

    @property
    def base(self) -> Any:
        """The running basenode process (log tail, stop, restart), or None."""
        return self._base

    @base.setter
    def base(self, handle: Any) -> None:
        # Set by wrap.start_base before the process starts: shutdown() stops whatever did start.
        self._base = handle

    @property
    def basenode_name(self) -> Optional[str]:
        """The basenode's full ROS name (``/move_base``), or None for a node that wraps nothing."""
        from .wrapping import base_fullname

        model = self._model
        return base_fullname(model) if model.base is not None else None

    @property
    def called(self) -> str:
        """How the user refers to this node, for advice in messages: the variable holding it, else its name."""
        return self._session.call_name(self)

    def register_params(self) -> int:
        """Set the node's parameters on the parameter server again (after a master restart); how many."""
        params = self.model().params
        self._set_params(params)
        return len(params)

    # -- lifecycle ------------------------------------------------------------------
    def create(self) -> "rosNode":
        """Start the node: everything declared so far begins to run."""
        with self._lock:
            if self.created:
                return self
            from .wrapping import start_base

            check_wrapping(self._model, [n._model for n in self._session.nodes.values() if n is not self and n.created])
            self._session.add(self)
            try:
                self._session.start_process_node(self.fullname)
                self._session.backend.open_host(self.fullname)
                self._session.require_master(f"{self.called}.create()")
                self._check_live_types(self._model.topics)
                self._set_params(self._model.params)
                self._output = self._session.output_scope(self)
                for slot in self._slots.values():  # heard again (quietened by a shutdown)
                    slot.closing = False
                self._open(planning.plan(self._model))
                self.created = True
                start_base(self)
                self._record("create()")
            except BaseException:
                self.shutdown()  # nothing half-started stays behind
                raise
            return self

    def shutdown(self) -> None:
        """Stop the node's publishers, subscribers, timers, services and its basenode."""
        self.quieten()
        with self._lock:
            if self.created:
                self._record("shutdown()")
            if self._base is not None:
                self._base.stop()
                self._base = None
            self._close_all()
            self._session.backend.close_host(self.fullname)
            self.created = False
            self._session.remove(self)

    def quieten(self) -> None:
        """Let the node's handlers fail silently from now on: it is shutting down (its timer's last call may
        find its publisher closed, which is no news). ``create()`` makes them heard again."""
        for slot in list(self._slots.values()):
            slot.closing = True

    # -- timers -----------------------------------------------------------------------
    def timer(self, period: float, handler: Callable[..., Any], *, name: Optional[str] = None,
              oneshot: bool = False) -> "rosNode":
        """Call ``handler`` every ``period`` seconds (once if ``oneshot``).

        Declaring a timer with the same ``name`` (default: the handler's name) replaces it.
        """
        if (isinstance(period, bool) or not isinstance(period, (int, float))
                or not MIN_TIMER_PERIOD <= period < float("inf")):
            raise DeclarationError(f"timer period must be a number of seconds from {MIN_TIMER_PERIOD:g} "
                                   f"(10 kHz) up, not {period!r}")
        name = name or getattr(handler, "__name__", "timer")
        if not isinstance(name, str) or not (re.fullmatch(r"\w+", name) or name == "<lambda>"):
            raise DeclarationError(f"timer name {cut(name)}: give letters, digits and _, e.g. name='heartbeat'")
        label = f"{self.name} timer {name}"
        takes_event = call_arity(handler, "timer", label)
        timer = TimerModel(name=name, period=float(period), handler=_name_of(handler), oneshot=oneshot)

        def edit(model: NodeModel) -> None:
            model.timers = [t for t in model.timers if t.name != name] + [timer]

        self._change(edit, {planning.timer_slot(name): (handler, takes_event)})
        self._record(f"timer {name} every {float(period):g} s -> {timer.handler}" + (" once" if oneshot else ""))
        return self

    # -- removal ---------------------------------------------------------------------
    def remove(self, topic: Optional[str] = None, *, timer: Optional[str] = None,
               service: Optional[str] = None) -> "rosNode":
        """Remove every declaration of ``topic``, or the named ``timer`` or ``service``."""
        if topic is not None:
            resolved = self._resolve(topic, "topic")
            if not any(t.resolved == resolved for t in self._model.topics):
                raise NotDeclaredError(f"{self.name} has no topic {resolved}; nd.model() lists what it has")

            def edit(model: NodeModel) -> None:
                model.topics = [t for t in model.topics if t.resolved != resolved]

            self._change(edit, drop=[planning.topic_slot(resolved)])
            self._record(f"remove {resolved}")
        if timer is not None:
            if self._model.timer(timer) is None:
                known = ", ".join(t.name for t in self._model.timers) or "none"
                raise NotDeclaredError(f"{self.name} has no timer {timer!r} (timers: {known})")
            self._change(lambda m: setattr(m, "timers", [t for t in m.timers if t.name != timer]),
                         drop=[planning.timer_slot(timer)])
            self._record(f"remove timer {timer}")
        if service is not None:
            resolved = self._resolve(service, "service")
            if not any(s.resolved == resolved for s in self._model.services):
                raise NotDeclaredError(f"{self.name} has no service {resolved}")
            self._change(lambda m: setattr(m, "services", [s for s in m.services if s.resolved != resolved]),
                         drop=[planning.service_slot(resolved)])
            self._record(f"remove service {resolved}")
        return self

    # -- writing ----------------------------------------------------------------------
    def write(self, topic: str, msg: Any) -> None:
        """Publish ``msg`` on ``topic``, which this node must publish."""
        writer = self._writers.get(topic)
        if writer is None:
            writer = self._writer(topic)
        publication, type_name = writer
        got = msgtypes.type_name(msg)  # a class of the right type is refused by the publication, in its words
        if got != type_name:
            got = got or type(msg).__name__
            raise MessageTypeError(f"{topic} carries {type_name}, not {got}; "
                                   f"build a {type_name.split('/')[1]}() and write that")
        publication.write(msg)

    def _writer(self, topic: str) -> tuple[Any, str]:
        resolved = self._resolve(topic, "topic")
        with self._lock:
            target = planning.write_target(self._model, resolved)
            if target is None:
                raise NotDeclaredError(
                    f"{self.name} does not publish {resolved}; declare it first: "
                    f"{self.name}.new.publish(topic={topic!r}, msgType=...)")
            if not self.created:
                raise NodeStateError(f"{self.name} is not running; call {self.name}.create() before write()")
            declared = next(t.type for t in self._model.topics if t.resolved == resolved)
            publication = next(ep for spec, ep in self._live.items()
                               if isinstance(spec, planning.PublishSpec) and spec.topic == target)
            self._writers[topic] = (publication, declared)
            return publication, declared

    # -- keeping the work ----------------------------------------------------------------
    def save(self, path: Any, namespace: Optional[dict] = None) -> Any:
        """Save the node to ``path``: ``.py`` as runnable DSL code, ``.yaml``/``.json`` as its model.

        The Python file (:mod:`ipyros.files.savefile`) brings the node back running when run;
        the model file (:mod:`ipyros.files.modelfile`, docs/model.md) is the node model plus handler
        sources, for tools. Handlers' globals are looked up in ``namespace`` first.
        """
        from ..files.modelfile import MODEL_SUFFIXES, save
        from ..files.savefile import save_nodes

        if not isinstance(path, (str, os.PathLike)):
            raise DeclarationError(f"save({cut(path)}): give a path ending in .py, .yaml or .json")
        if Path(path).expanduser().is_dir():
            raise DeclarationError(f"save({str(path)!r}): that is a directory; give a file, e.g. "
                                   f"{os.path.join(str(path), self.name + '.py')!r}")
        suffix = str(path).rsplit(".", 1)[-1].lower() if "." in str(path) else ""
        if suffix == "py":
            return save_nodes([self], path, namespace)
        if suffix in MODEL_SUFFIXES:
            return save(self, path)
        raise DeclarationError(f"{path}: say what to save by the suffix: .py (runnable code) "
                               "or .yaml / .json (the node model)")

    @classmethod
    def load(cls, path: Any, namespace: Optional[dict] = None, create: bool = False, *,
             session: Optional[Session] = None, trust: bool = False) -> "rosNode":
        """Bring back a node saved by :meth:`save` (``.py`` runs the file; a model file is declared).

        Handlers are defined in ``namespace`` (in IPython: ``get_ipython().user_ns``); a
        ``.py`` file creates the node if it was running when saved; ``create=True`` also
        creates a node loaded from a model file. A model file that carries code (imports,
        handler sources) is refused unless ``trust=True``: it looks like data, so its code
        does not run without being asked; a ``.py`` file is code and runs as such.
        """
        from ..files.modelfile import load
        from ..files.savefile import restore

        if str(path).endswith(".py"):
            nodes = restore(path, namespace)
            if len(nodes) != 1:
                raise DeclarationError(f"{path} holds {len(nodes)} nodes ({', '.join(n.name for n in nodes)}); "
                                       "ipyros.restore(path) brings them all back")
            node = nodes[0]
        else:
            node = load(path, namespace, session=session, trust=trust)
        return node.create() if create else node

    def export(self, path: Any, namespace: Optional[dict] = None) -> Any:
        """Export this node to run without ipyros: a ``.py`` path is one standalone rospy script; any other
        path becomes a ROS package (package.xml, scripts/<node>, launch/<node>.launch with its basenode);
        see :mod:`ipyros.files.export`."""
        from ..files.export import export

        if not isinstance(path, (str, os.PathLike)):
            raise DeclarationError(f"export({cut(path)}): give a path: 'my_node.py' (one script) or 'my_node_pkg' "
                                   "(a ROS package)")

        return export(self, path, namespace)

    # -- status and display ---------------------------------------------------------------
    def status(self) -> "Any":
        """Per topic, timer and service: rate, handler time and exception count."""
        from ..ipython.display import NodeStatus

        return NodeStatus.of(self)

    def slot(self, key: str) -> Optional[HandlerSlot]:
        """The handler slot ``key`` (see :mod:`ipyros.core.plan`: ``"topic /x"``, ``"timer t"``), if it runs."""
        return self._slots.get(key)

    def slots(self) -> dict[str, HandlerSlot]:
        """Every running handler slot of the node, by key."""
        with self._lock:
            return dict(self._slots)

    def sent(self) -> list[Any]:
        """Per topic the node sends on (publications, relays): messages, subscribers, and drops
        for subscribers that could not keep up (:class:`ipyros.core.slots.SendFigures`)."""
        with self._lock:
            return [endpoint.figures() for endpoint in self._live.values() if hasattr(endpoint, "figures")]

    def __repr__(self) -> str:
        state = "running" if self.created else "declared"
        return f"<rosNode {self.fullname} ({state}): {len(self._model.topics)} topics, " \
               f"{len(self._model.timers)} timers, {len(self._model.services)} services>"

    def __rich__(self) -> Any:
        from ..ipython.display import node_table

        return node_table(self)

    def _repr_pretty_(self, printer: Any, cycle: bool) -> None:
        from ..ipython.display import render_text

        printer.text(repr(self) if cycle else render_text(self.__rich__()))

    def _repr_html_(self) -> str:
        from ..ipython.display import render_html

        return render_html(self.__rich__())

    # -- the one place where the model and the live node change ------------------------------
    def _change(self, edit: Callable[[NodeModel], None],
                handlers: Optional[dict[str, tuple[Callable[..., Any], bool]]] = None,
                drop: tuple[str, ...] | list[str] = (), check: tuple[TopicModel, ...] = ()) -> None:
        """Apply ``edit`` to a copy of the model; if the node runs, reconcile; then commit.

        Either everything happens or nothing does: a failure while opening endpoints closes
        what was opened and reopens what was closed.
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
            self._model = new_model
            self._writers.clear()

    def _reconcile(self, new_model: NodeModel, handlers: dict[str, tuple[Callable[..., Any], bool]]) -> None:
        old = planning.plan(self._model)
        new = planning.plan(new_model)
        removed = [s for s in old if s not in new]
        added = [s for s in new if s not in old]
        if added:
            self._session.require_master(f"opening {', '.join(_describe(s) for s in added)} on {self.name}")
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
        backend, host = self._session.backend, self.fullname
        if isinstance(spec, planning.PublishSpec):
            qos = replace(spec.qos, durability="transient_local") if spec.latch else spec.qos
            return backend.publication(host, spec.topic, msgtypes.resolve_message(spec.type)[1], qos, self._complain)
        if isinstance(spec, planning.RelaySpec):
            def wrong_type(got: str, spec: planning.RelaySpec = spec) -> None:
                self._session.notify(f"ipyros: {spec.source} carries {got}, but {self.name} relays it as {spec.type}; "
                                     f"messages are dropped: declare type={got!r}")

            return backend.relay(host, spec.source, spec.target, msgtypes.resolve_message(spec.type)[1], wrong_type,
                                 self._complain)
        if isinstance(spec, planning.ServiceRelaySpec):
            return backend.service_relay(host, spec.source, spec.target, msgtypes.resolve_service(spec.type)[1],
                                         self._complain)
        slot = self._slots.get(spec.slot)
        if slot is None:
            label = f"{self.name} {spec.slot.split(' ', 1)[1]}"
            slot = HandlerSlot(label, handlers[spec.slot], self._report, pass_argument=takes_arg.get(spec.slot, True),
                               keep=self._session.config.keep_recent, output=self._output)
            self._slots[spec.slot] = slot
        if isinstance(spec, planning.SubscribeSpec):
            return backend.subscription(host, spec.topic, msgtypes.resolve_message(spec.type)[1], slot, spec.qos,
                                        self._complain)
        if isinstance(spec, planning.TimerSpec):
            return backend.timer(host, spec.period, slot, spec.oneshot, self._complain)
        return backend.service(host, spec.name, msgtypes.resolve_service(spec.type)[1], slot)

    def _complain(self, text: str) -> None:
        """What the backend finds wrong with a live endpoint of this node, told at the prompt."""
        self._session.notify(f"ipyros: {self.name}: {text}")

    def _record(self, change: str) -> None:
        pending, self._new_version = self._new_version, None
        if pending is None:
            self._session.record(self.fullname, change)
            return
        slot, version = pending
        if self._reverting is not None:
            change = f"revert {slot} to version {version.number} ({version.name})"
        self._session.record(self.fullname, change, slot=slot, version=version.number, handler=version.name,
                             source=version.source)

    def _snapshot(self) -> tuple:
        """What a declaration chain may have to come back to: the model, the handlers and their versions."""
        with self._lock:
            return (copy.deepcopy(self._model), dict(self._handlers), dict(self._takes_argument),
                    {slot: list(found) for slot, found in self._versions.items()}, dict(self._current_version))

    def _restore(self, snapshot: tuple, change: str) -> None:
        """Make the node (live, if it runs) what it was at ``snapshot``, as one recorded change."""
        model, handlers, takes, versions, current = snapshot
        with self._lock:
            def edit(new: NodeModel) -> None:
                new.__dict__.update(copy.deepcopy(model).__dict__)

            swapped = {k: (h, takes.get(k, True)) for k, h in handlers.items() if self._handlers.get(k) is not h}
            self._change(edit, swapped, drop=[k for k in self._handlers if k not in handlers])
            self._versions, self._current_version, self._new_version = versions, current, None
            self._record(change)

    # -- handler versions --------------------------------------------------------------
    def _add_version(self, slot: str, handler: Callable[..., Any]) -> None:
        """Note that ``slot`` is now served by ``handler``: a new version, or an old one brought back."""
        versions = self._versions.setdefault(slot, [])
        if self._reverting is not None:
            version = versions[self._reverting - 1]
        else:
            version = HandlerVersion(len(versions) + 1, time.time(), _name_of(handler) or "handler",
                                     versions_mod.source_of(handler), handler)
            versions.append(version)
        self._current_version[slot] = version.number
        self._new_version = (slot, version)

    def versions(self, what: str) -> Any:
        """Every function the handler of ``what`` (a topic, timer name or service) was given, oldest first.

        Displays as a table; ``nd.versions("cmd_vel")[0].source`` is the first one's source.
        """
        from ..ipython.display import Versions
        from ..tools.editing import find_target

        target = find_target(self, what)
        with self._lock:
            return Versions(f"{self.name} {target.label}", tuple(self._versions.get(target.slot, ())),
                            self._current_version.get(target.slot))

    def revert(self, what: str, version: int) -> "rosNode":
        """Serve ``what`` with handler ``version`` again (see :meth:`versions`), live, no message lost."""
        from ..tools.editing import current_handler, find_target, redeclare

        target = find_target(self, what)
        with self._lock:
            known = self._versions.get(target.slot, [])
            if isinstance(version, bool) or not isinstance(version, int) or not 1 <= version <= len(known):
                raise NotDeclaredError(f"{self.name} {target.label} has versions 1 to {len(known)}, not {version!r}; "
                                       f"{self.name}.versions({what!r}) lists them")
            chosen = known[version - 1]
            if chosen.function is None:
                namespace = getattr(current_handler(self, target), "__globals__", {})
                chosen.function = versions_mod.compile_version(chosen, namespace, f"{self.name} {target.label}")
            self._reverting = version
            try:
                redeclare(self, target, chosen.function)
            finally:
                self._reverting = None
        return self

    def restore_versions(self, what: str, versions: list[tuple[str, str]], current: Optional[int] = None) -> "rosNode":
        """Give the handler of ``what`` its past: every version as ``(time, source)``, oldest first.

        Version ``current`` (default: the last) is the function serving now; the others
        are kept as source and compiled by :meth:`revert` when chosen, in the namespace
        of the handler then serving. This is how a saved file brings versions back.
        """
        from ..tools.editing import current_handler, find_target

        target = find_target(self, what)
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
            restored.append(HandlerVersion(number, versions_mod.parse_time(when), _defined_name(source), source))
        with self._lock:
            restored[current - 1].function = current_handler(self, target)
            self._versions[target.slot] = restored
            self._current_version[target.slot] = current
        return self

    def history(self) -> Any:
        """Every change of this node so far, oldest first (a table in IPython)."""
        from ..ipython.display import History

        journal = self._session.journal
        return History(self.fullname, tuple(c for c in self._session.history if c.node == self.fullname),
                       journal.path if journal else None)

    def _report(self, failure: Any) -> None:
        self._session.report(failure)

    def _close_all(self) -> None:
        for spec in reversed(list(self._live)):
            try:
                self._live.pop(spec).close()
            except Exception:  # closing must go on: a half-closed node is worse
                pass
        self._writers.clear()

    def _check_live_types(self, topics: Any) -> None:
        """Refuse a declared type that differs from the type a live topic already has.

        The master remembers a topic's type after everyone left it, so only topics with a
        publisher or subscriber count; the ones only this session uses are checked against
        the session's other nodes (this node may change its own topic's type).
        """
        if not topics or self._session.master is None:
            return
        from ..tools.graph import fetch_snapshot

        live = fetch_snapshot(self._session.master.uri, timeout=2.0)  # live topics only, one round trip
        me = self._session.process.name
        for t in topics:
            have = live.topics.get(t.resolved)
            users = {*live.publishers.get(t.resolved, ()), *live.subscribers.get(t.resolved, ())}
            if not have or have == t.type or have == "*":
                continue
            if users == {me}:
                have = next((o.type for n in self._session.nodes.values() if n is not self
                             for o in n._model.topics if o.resolved == t.resolved and o.type != t.type), None)
                if have is None:
                    continue
            raise TopicTypeConflict(f"{t.resolved} already carries {have}, not {t.type}; "
                                    f"declare msgType={have!r} or use another topic name")

    def _set_params(self, params: dict[str, Any]) -> None:
        for key, value in params.items():
            self._session.backend.set_param(self._resolve("~" + key, "parameter"), value)


class _Chain:
    """One chain of declarations (``nd.new.subscribe(...).publish(...)``): all of it applies, or none.

    Each call of a chain is applied as it comes (a running node changes at once); if a
    later call fails, the earlier ones are undone, so that a chain is one change. A chain
    ends when the prompt shows it, when the cell that typed it has run (the extension
    says so: :func:`end_chains`), or when ``.create()`` ends it.
    """

    def __init__(self, snapshot: Any) -> None:
        self.snapshot = snapshot
        self.parts: list[str] = []
        self.open = True


_open_chains: "weakref.WeakSet[_Chain]" = weakref.WeakSet()


def end_chains() -> None:
    """End every open declaration chain (after a cell has run): a later call on one starts a new chain."""
    for chain in list(_open_chains):
        chain.open = False
    _open_chains.clear()


class TopicHandler:
    """``node.new`` or ``node.reuse``: declares topics and services, chainable; a chain is all or nothing."""

    def __init__(self, node: rosNode, role: str, chain: Optional[_Chain] = None) -> None:
        self._node = node
        self._role = role
        self._chain = chain

    def __repr__(self) -> str:
        # A chain typed at the prompt shows what it did, in one line, not an object address.
        node = self._node
        state = "live" if node.created else "declared, not created yet"
        chain = self._chain
        done = "; ".join(chain.parts) if chain is not None and chain.parts else \
            "subscribe(), publish(), service(), unsubscribe(), unpublish()"
        if chain is not None:
            chain.open = False
        return f"{node.name}.{self._role}: {done} ({state})"

    @contextlib.contextmanager
    def _part(self, call: str) -> Iterator["TopicHandler"]:
        """One call of a chain: yields the handler the chain goes on with; a failure undoes the chain's earlier calls."""
        link = self
        if self._chain is None or not self._chain.open:
            chain = _Chain(self._node._snapshot())
            _open_chains.add(chain)
            link = TopicHandler(self._node, self._role, chain)
        chain = link._chain
        assert chain is not None
        try:
            yield link
        except IpyrosError as error:
            if not chain.parts:
                raise
            done = "; ".join(f"{self._role}.{part}" for part in chain.parts)
            try:
                self._node._restore(chain.snapshot, f"undo {done} ({self._role}.{call} failed)")
            except Exception as undo:  # noqa: BLE001 - said, with the error that matters first
                raise type(error)(f"{self._role}.{call} (call {len(chain.parts) + 1} of the chain) failed: {error}; "
                                  f"undoing the calls before it ({done}) failed too: {undo}") from None
            chain.open = False
            raise type(error)(f"{self._role}.{call} (call {len(chain.parts) + 1} of the chain) failed: {error}; "
                              f"the calls before it ({done}) were undone: the chain changed nothing") from None

    def _did(self, text: str) -> None:
        assert self._chain is not None
        self._chain.parts.append(text)
        self._node._record(f"{self._role}.{text}")

    def subscribe(self, topic: str, handler: Optional[Callable[..., Any]] = None, msgType: Any = _UNSET,
                  type: Any = _UNSET, qos: Any = None) -> "TopicHandler":  # noqa: A002,N803 - the paper's names
        """Subscribe ``handler(msg)`` to ``topic``; declaring it again swaps the handler live.

        ``qos``: a profile name (``"sensor_data"``, ``"best_effort"``, ``"transient_local"``, ...),
        a depth, or a dict of depth, reliability, durability (see :mod:`ipyros.core.qos`).
        """
        with self._part(f"subscribe({topic!r})") as link:
            return link._subscribe(topic, handler, _one_type(msgType, type, topic), qos)

    def _subscribe(self, topic: str, handler: Optional[Callable[..., Any]], msg_type: Any, qos: Any) -> "TopicHandler":
        node, role = self._node, self._role
        resolved = node._resolve_as(role, topic, "topic")
        type_name, _ = msgtypes.resolve_message(msg_type)
        given = self._qos(qos, f"{role}.subscribe({topic!r})")
        if role == "reuse":
            check_reuse(node._model, resolved, "subscribe")
        label = f"{node.name} {resolved}"
        handlers = {}
        if role == "new":
            if handler is None:
                raise HandlerError(f"new.subscribe({topic!r}) needs handler=...: the function called with "
                                   "each message")
            handlers[planning.topic_slot(resolved)] = (handler, call_arity(handler, "subscribe", label))
        elif handler is not None:
            raise HandlerError(f"reuse.subscribe({topic!r}) relays messages unchanged and takes no handler; "
                               "to handle them use new.subscribe(..., handler=...)")
        entry = TopicModel(topic, resolved, "subscribe", type_name, role, _name_of(handler), qos=given.to_model())
        node._change(_replace_topic(entry), handlers, check=(entry,))
        self._did(f"subscribe {resolved} [{type_name}]" + (f" -> {entry.handler}" if handler else ""))
        return self

    def publish(self, topic: str, msgType: Any = _UNSET, type: Any = _UNSET,
                latch: bool = False, qos: Any = None) -> "TopicHandler":  # noqa: A002,N803 - the paper's names
        """Publish ``topic``; ``node.write(topic, msg)`` sends on it.

        ``latch``: a subscriber that connects later gets the last message (on ROS 2,
        transient-local durability); ``qos`` as for :meth:`subscribe`.
        """
        with self._part(f"publish({topic!r})") as link:
            return link._publish(topic, _one_type(msgType, type, topic), latch, qos)

    def _publish(self, topic: str, msg_type: Any, latch: bool, qos: Any) -> "TopicHandler":
        node = self._node
        resolved = node._resolve_as(self._role, topic, "topic")
        type_name, _ = msgtypes.resolve_message(msg_type)
        where = f"{self._role}.publish({topic!r})"
        given = self._qos(qos, where)
        if latch and given.durability == "volatile":
            raise DeclarationError(f"{where}: latch=True and a volatile qos contradict each other; "
                                   "drop one (latch=True is qos durability transient_local)")
        if self._role == "reuse":
            check_reuse(node._model, resolved, "publish")
        entry = TopicModel(topic, resolved, "publish", type_name, self._role, None, bool(latch), given.to_model())
        node._change(_replace_topic(entry), check=(entry,))
        self._did(f"publish {resolved} [{type_name}]")
        return self

    def _qos(self, value: Any, where: str) -> qos_mod.Qos:
        """``qos=`` checked; refused on reuse, whose relays take the QoS of what they relay."""
        if value is not None and self._role == "reuse":
            raise DeclarationError(f"{where}: a reuse relay takes the QoS of the publishers it relays and "
                                   "takes no qos=; give qos= to new.subscribe or new.publish")
        return qos_mod.parse(value, where)

    def create(self) -> rosNode:
        """Create the node, so a declaration chain can end with ``.create()`` (which ends the chain)."""
        if self._chain is not None:
            self._chain.open = False
        return self._node.create()

    def unsubscribe(self, topic: str) -> "TopicHandler":
        """Drop this role's subscription to ``topic``."""
        with self._part(f"unsubscribe({topic!r})") as link:
            return link._drop(topic, "subscribe")

    def unpublish(self, topic: str) -> "TopicHandler":
        """Drop this role's publication of ``topic``."""
        with self._part(f"unpublish({topic!r})") as link:
            return link._drop(topic, "publish")

    def _drop(self, topic: str, direction: str) -> "TopicHandler":
        node, role = self._node, self._role
        resolved = node._resolve_as(role, topic, "topic")
        if node._model.topic(resolved, direction, role) is None:  # type: ignore[arg-type]
            raise NotDeclaredError(f"{node.name} has no {role}.{direction} of {resolved}")

        def edit(model: NodeModel) -> None:
            model.topics = [t for t in model.topics
                            if not (t.resolved == resolved and t.direction == direction and t.role == role)]

        drop = [planning.topic_slot(resolved)] if direction == "subscribe" and role == "new" else []
        node._change(edit, drop=drop)
        self._did(f"removed {direction} {resolved}")
        return self

    def service(self, name: str, srvType: Any = _UNSET, handler: Optional[Callable[..., Any]] = None,
                type: Any = _UNSET) -> "TopicHandler":  # noqa: A002,N803
        """Serve ``name`` with ``handler(request) -> response`` (new), or relay the basenode's (reuse)."""
        with self._part(f"service({name!r})") as link:
            return link._service(name, _one_type(srvType, type, name), handler)

    def _service(self, name: str, srv_type: Any, handler: Optional[Callable[..., Any]]) -> "TopicHandler":
        node, role = self._node, self._role
        resolved = node._resolve_as(role, name, "service")
        type_name, _ = msgtypes.resolve_service(srv_type)
        handlers = {}
        if role == "new":
            if handler is None:
                raise HandlerError(f"new.service({name!r}) needs handler=...: called with each request, "
                                   "returns the response")
            handlers[planning.service_slot(resolved)] = (handler, call_arity(handler, "service", f"{node.name} {resolved}"))
        elif handler is not None:
            raise HandlerError(f"reuse.service({name!r}) relays the basenode's service and takes no handler; "
                               "to answer it yourself use new.service(..., handler=...)")
        entry = ServiceModel(name, resolved, type_name, role, _name_of(handler))

        def edit(model: NodeModel) -> None:
            model.services = [s for s in model.services if not (s.resolved == resolved and s.role == role)]
            model.services.append(entry)

        node._change(edit, handlers)
        self._did(f"service {resolved} [{type_name}]" + (f" -> {entry.handler}" if handler else ""))
        return self


class NodeParams(MutableMapping):
    """The node's private (``~name``) parameters: live on the parameter server once created."""

    def __init__(self, node: rosNode) -> None:
        self._node = node
        self._backend = node.session.backend

    def _name(self, key: str) -> str:
        if not isinstance(key, str) or key.startswith(("/", "~")):
            raise DeclarationError(f"parameter key {key!r}: give the private name without ~ or /, e.g. 'gain'")
        names.check_param_key(key, f"{self._node.name}.params")
        return self._node._resolve("~" + key, "parameter")

    def __getitem__(self, key: str) -> Any:
        name = self._name(key)
        if self._node.created:
            if not self._backend.has_param(name):
                raise self._missing(key)
            return self._backend.get_param(name)
        if key not in self._node._model.params:
            raise self._missing(key)
        return self._node._model.params[key]

    def _missing(self, key: str) -> KeyError:
        """A KeyError, as a mapping raises, that says which parameters there are."""
        have = ", ".join(repr(k) for k in self._node._model.params) or "none yet"
        return KeyError(f"{self._node.name} has no parameter {key!r} (it has {have}); "
                        f"set one with {self._node.called}.params[{key!r}] = value")

    def __setitem__(self, key: str, value: Any) -> None:
        name = self._name(key)
        self._backend.check_param(name, value)
        node = self._node
        with node._lock:
            if node.created:
                node._session.require_master(f"{node.called}.params[{key!r}] = ...")
                self._backend.set_param(name, value)
            node._model.params[key] = value
            node._record(f"params[{key!r}] = {value!r}")

    def __delitem__(self, key: str) -> None:
        name = self._name(key)
        node = self._node
        with node._lock:
            if key not in node._model.params and not (node.created and self._backend.has_param(name)):
                raise self._missing(key)
            if node.created and self._backend.has_param(name):
                self._backend.delete_param(name)
            node._model.params.pop(key, None)

    def __iter__(self) -> Iterator[str]:
        return iter(list(self._node._model.params))

    def __len__(self) -> int:
        return len(self._node._model.params)

    def __repr__(self) -> str:
        return f"<{self._node.name}.params {dict(self.items())!r}>"


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


def _one_type(msg_type: Any, type_: Any, name: str) -> Any:
    if msg_type is not _UNSET and type_ is not _UNSET and msg_type is not type_ and msg_type != type_:
        raise MessageTypeError(f"{name}: msgType={msg_type!r} and type={type_!r} disagree; give just one")
    chosen = msg_type if msg_type is not _UNSET else type_
    if chosen is _UNSET:
        raise MessageTypeError(f"{name}: no message type given; add msgType=... e.g. msgType=Twist "
                               "or msgType='geometry_msgs/Twist'")
    return chosen


def _describe(spec: Spec) -> str:
    """``publisher /x``, ``relay /a -> /b``: an endpoint of the plan in a few words."""
    kind = {"PublishSpec": "publisher", "SubscribeSpec": "subscriber", "ServiceRelaySpec": "service relay"}.get(
        type(spec).__name__, type(spec).__name__.removesuffix("Spec").lower())
    if isinstance(spec, (planning.RelaySpec, planning.ServiceRelaySpec)):
        return f"{kind} {spec.source} -> {spec.target}"
    return f"{kind} {getattr(spec, 'topic', None) or getattr(spec, 'name', '')}"


def _defined_name(source: str) -> str:
    """The name a handler's source defines: ``def name(...)``, else ``<lambda>``."""
    match = re.match(r"\s*(?:async\s+)?def\s+(\w+)", source)
    return match.group(1) if match else "<lambda>"


def _name_of(handler: Any) -> Optional[str]:
    return None if handler is None else getattr(handler, "__name__", type(handler).__name__)
