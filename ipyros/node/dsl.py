"""The paper's internal DSL: ``rosNode``, ``new``/``reuse``, ``subscribe``, ``publish``, ``create``, ``write``.

Each call validates its input and edits the node's :class:`~ipyros.core.model.NodeModel`
through its :class:`~ipyros.node.engine.NodeEngine`, which makes the live node match at once
once the node runs (:mod:`ipyros.core.plan` says which endpoints must exist; the session's
backend, :mod:`ipyros.node.backend`, opens and closes them). A rejected declaration raises a
one-line error and changes nothing, neither model nor running node. A ``rosNode`` holds the
DSL and nothing else: ``nd.<TAB>`` shows the paper's methods and how to keep the work.

    nd = rosNode("turtle_control_node")
    (nd.new.subscribe(topic="/turtle1/pose", handler=showPose, msgType=Pose)
           .publish(topic="/turtle1/cmd_vel", msgType=Twist))
    nd.create()
    nd.write("/turtle1/cmd_vel", msg)
"""

from __future__ import annotations

import contextlib
import os
import re
import weakref
from collections.abc import MutableMapping
from pathlib import Path
from typing import Any, Callable, Iterator, Optional

from ..core import msgtypes, names, plan as planning, qos as qos_mod
from ..core.errors import (
    DeclarationError,
    HandlerError,
    IpyrosError,
    MessageTypeError,
    NotDeclaredError,
    TopicTypeConflict,
    cut,
)
from ..core.model import NodeModel, ServiceModel, TimerModel, TopicModel
from ..core.records import History, NodeStatus, Versions
from ..core.slots import call_arity
from ..core.versions import name_of
from .engine import NodeEngine
from .session import Session, current
from .wrapping import check_reuse, discover, set_bag, set_base, set_launch_base

__all__ = ["NodeParams", "TopicHandler", "end_chains", "engine_of", "rosNode"]

_UNSET: Any = object()
MIN_TIMER_PERIOD = 1e-4  # seconds; below it a timer would only spin a core (and rospy divides by it)


class rosNode:  # noqa: N801 - the paper's name
    """A ROS node declared, created and reshaped from the prompt.

    ``namespace`` defaults to ``ROS_NAMESPACE`` (or ``/``). Several rosNodes can live in one
    session (on ROS 1 they share the process's one rospy node; see the README).
    """

    def __init__(self, name: str = _UNSET, namespace: Optional[str] = None, *, session: Optional[Session] = None,
                 **unknown: Any) -> None:
        if name is _UNSET or unknown:
            given = f"got unknown keyword argument(s) {', '.join(sorted(unknown))}; it" if unknown else "needs a name:"
            raise TypeError(f"rosNode() {given} takes name and namespace, e.g. rosNode('turtle_control_node') "
                            "or rosNode('planner', namespace='/robot1')")
        ns = names.default_namespace() if namespace is None else names.check_namespace(namespace)
        model = NodeModel(name=names.check_node_name(name), namespace=ns)
        # A wrapping node without a namespace of its own lives in its basenode's (see wrapping.set_base).
        self._engine = NodeEngine(self, model, session or current(), explicit_namespace=namespace is not None)
        self.new = TopicHandler(self._engine, "new")
        self.reuse = TopicHandler(self._engine, "reuse")
        self.params = NodeParams(self._engine)

    # -- what it is ---------------------------------------------------------------------------
    @property
    def name(self) -> str:
        return self._engine.name

    @property
    def fullname(self) -> str:
        return self._engine.fullname

    @property
    def created(self) -> bool:
        """Whether the node runs (``create()`` was called and ``shutdown()`` not since)."""
        return self._engine.created

    @property
    def ros_name(self) -> Optional[str]:
        """The ROS node that hosts this node's endpoints (ROS 1: the process's one, shared)."""
        return self._engine.session.process.name if self.created else None

    @property
    def base(self) -> Any:
        """The running basenode (``tail()``, ``stop()``, ``restart()``), or None."""
        return self._engine.base

    @property
    def basenode_name(self) -> Optional[str]:
        """The basenode's full ROS name (``/move_base``), or None for a node that wraps nothing."""
        return self._engine.basenode_name

    def model(self) -> NodeModel:
        """A copy of the declared structure, as plain data."""
        return self._engine.model()

    def handler(self, topic: str) -> Optional[Callable[..., Any]]:
        """The function now serving subscription ``topic`` (or the service or timer of that name)."""
        return self._engine.handler(topic)

    def resolve(self, name: str) -> str:
        """The global name ``name`` has for this node."""
        return self._engine.resolve(name)

    # -- the basenode ----------------------------------------------------------------
    def baseNode(self, executable: str, **options: Any) -> "rosNode":  # noqa: N802 - the paper's name
        """Wrap the basenode run by ``executable`` (its package is given by :meth:`basePackage`).

        Options: ``name`` (node name, default the executable's), ``namespace``, ``remaps``
        (dict), ``params`` (private parameters), ``args`` (list of arguments).
        """
        set_base(self._engine, executable=executable, **options)
        return self

    def basePackage(self, package: str) -> "rosNode":  # noqa: N802 - the paper's name
        """The package of the basenode, found as rosrun (ROS 2: ros2 run) finds it."""
        set_base(self._engine, package=package)
        return self

    def baseLaunch(self, launch: str, node: str, args: Optional[dict[str, Any]] = None,
                   **arg_values: Any) -> "rosNode":  # noqa: N802 - named like baseNode
        """Wrap the node ``node`` that the launch file ``launch`` starts (``/robot1/planner``).

        The file's ``<arg>`` values are given as keywords (``rate=5``) or, for names that
        are not Python identifiers, as ``args={"use-sim": True}``, like
        ``roslaunch FILE rate:=5``. Its package, executable, name, namespace, remaps,
        params and args come from the launch file; ``create()`` runs the rest of the launch
        file untouched, and this node wrapped where it was. The file itself is not edited.
        """
        if args is not None and not isinstance(args, dict):
            raise DeclarationError(f"baseLaunch(args={cut(args)}): give a dict of the launch file's args, "
                                   "e.g. args={'rate': 5}")
        set_launch_base(self._engine, launch, node, {**(args or {}), **arg_values})
        return self

    def baseBag(self, path: Any, rate: float = 1.0, loop: bool = False, topics: Optional[list[str]] = None,
                delay: float = 5.0) -> "rosNode":  # noqa: N802 - named like baseNode
        """Wrap a recorded bag as the basenode: a bag player (like ``rosbag play``) publishes its
        topics, remapped like any basenode's, so that ``reuse`` and ``new.subscribe`` work on
        recorded data as on a live node, and ``nd.base.restart()`` plays it again (after a
        handler change: the same messages, new behaviour).

        ``rate`` scales the playing speed, ``loop`` plays it again and again, ``topics`` plays
        only these; the player waits until each topic has a subscriber, ``delay`` seconds at most.
        """
        set_bag(self._engine, path, rate, loop, topics, delay)
        return self

    def discover(self, timeout: float = 10.0) -> Any:
        """Run the basenode once, read its topics and services from the graph, reuse them all.

        Returns the discovered interface (it displays as a table).
        """
        return discover(self._engine, timeout)

    # -- its life ------------------------------------------------------------------
    def create(self) -> "rosNode":
        """Start the node: everything declared so far begins to run."""
        self._engine.create()
        return self

    def shutdown(self) -> None:
        """Stop the node's publishers, subscribers, timers, services and its basenode."""
        self._engine.shutdown()

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
        takes_event = call_arity(handler, "timer", f"{self.name} timer {name}")
        timer = TimerModel(name=name, period=float(period), handler=name_of(handler) or "timer", oneshot=oneshot)

        def edit(model: NodeModel) -> None:
            model.timers = [t for t in model.timers if t.name != name] + [timer]

        self._engine.change(edit, {planning.timer_slot(name): (handler, takes_event)})
        self._engine.record(f"timer {name} every {float(period):g} s -> {timer.handler}" + (" once" if oneshot else ""))
        return self

    # -- removal ---------------------------------------------------------------------
    def remove(self, topic: Optional[str] = None, *, timer: Optional[str] = None,
               service: Optional[str] = None) -> "rosNode":
        """Remove every declaration of ``topic``, or the named ``timer`` or ``service``."""
        engine, model = self._engine, self._engine.model()
        if topic is not None:
            resolved = engine.resolve(topic)
            if not any(t.resolved == resolved for t in model.topics):
                raise NotDeclaredError(f"{self.name} has no topic {resolved}; {engine.called}.model() lists what "
                                       "it has")
            engine.change(lambda m: setattr(m, "topics", [t for t in m.topics if t.resolved != resolved]),
                          drop=[planning.topic_slot(resolved)])
            engine.record(f"remove {resolved}")
        if timer is not None:
            if model.timer(timer) is None:
                known = ", ".join(t.name for t in model.timers) or "none"
                raise NotDeclaredError(f"{self.name} has no timer {timer!r} (timers: {known})")
            engine.change(lambda m: setattr(m, "timers", [t for t in m.timers if t.name != timer]),
                          drop=[planning.timer_slot(timer)])
            engine.record(f"remove timer {timer}")
        if service is not None:
            resolved = engine.resolve(service, "service")
            if not any(s.resolved == resolved for s in model.services):
                raise NotDeclaredError(f"{self.name} has no service {resolved}")
            engine.change(lambda m: setattr(m, "services", [s for s in m.services if s.resolved != resolved]),
                          drop=[planning.service_slot(resolved)])
            engine.record(f"remove service {resolved}")
        return self

    # -- writing ----------------------------------------------------------------------
    def write(self, topic: str, msg: Any) -> None:
        """Publish ``msg`` on ``topic``, which this node must publish."""
        self._engine.write(topic, msg)

    # -- keeping the work ----------------------------------------------------------------
    # Saving and exporting belong to the files layer, above this one: these methods reach up to
    # it (the paper's DSL offers them on the node), through _keeping() alone.
    def save(self, path: Any, namespace: Optional[dict] = None) -> Path:
        """Save the node to ``path``: ``.py`` as runnable DSL code, ``.yaml``/``.json`` as its model.

        The Python file (:mod:`ipyros.files.savefile`) brings the node back running when run;
        the model file (:mod:`ipyros.files.modelfile`, docs/model.md) is the node model plus handler
        sources, for tools. Handlers' globals are looked up in ``namespace`` first.
        """
        if not isinstance(path, (str, os.PathLike)):
            raise DeclarationError(f"save({cut(path)}): give a path ending in .py, .yaml or .json")
        if Path(path).expanduser().is_dir():
            raise DeclarationError(f"save({str(path)!r}): that is a directory; give a file, e.g. "
                                   f"{os.path.join(str(path), self.name + '.py')!r}")
        return _keeping().save(self, path, namespace)

    @classmethod
    def load(cls, path: Any, namespace: Optional[dict] = None, create: bool = False, *,
             session: Optional[Session] = None, trust: bool = False) -> "rosNode":
        """Bring back a node saved by :meth:`save` (``.py`` runs the file; a model file is declared).

        Handlers are defined in ``namespace`` (in IPython: ``get_ipython().user_ns``); a
        ``.py`` file creates the node if it was running when saved; ``create=True`` also
        creates a node loaded from a model file. A model file that would run anything
        (handler sources, imports, a basenode) is refused unless ``trust=True``: it looks like
        data, so nothing in it runs without being asked; a ``.py`` file is code and runs as such.
        """
        return _keeping().load(path, namespace, create=create, session=session, trust=trust)

    def export(self, path: Any, namespace: Optional[dict] = None) -> Path:
        """Export this node to run without ipyros: a ``.py`` path is one standalone script; any other
        path becomes a ROS package (package.xml, scripts/<node>, launch/<node>.launch with its basenode);
        see :mod:`ipyros.files.export`."""
        if not isinstance(path, (str, os.PathLike)):
            raise DeclarationError(f"export({cut(path)}): give a path: 'my_node.py' (one script) or 'my_node_pkg' "
                                   "(a ROS package)")
        return _keeping().export(self, path, namespace)

    # -- what it did ---------------------------------------------------------------
    def status(self) -> NodeStatus:
        """Per topic, timer and service: rate, handler time and exception count."""
        return self._engine.status()

    def history(self) -> History:
        """Every change of this node so far, oldest first (a table in IPython)."""
        return self._engine.history()

    def versions(self, what: str) -> Versions:
        """Every function the handler of ``what`` (a topic, timer name or service) was given, oldest first.

        Displays as a table; ``nd.versions("cmd_vel")[0].source`` is the first one's source.
        """
        return self._engine.versions(what)

    def revert(self, what: str, version: int) -> "rosNode":
        """Serve ``what`` with handler ``version`` again (see :meth:`versions`), live, no message lost."""
        self._engine.revert(what, version)
        return self

    def restore_versions(self, what: str, versions: list[tuple[str, str]], current: Optional[int] = None) -> "rosNode":
        """Give the handler of ``what`` its past: every version as ``(time, source)``, oldest first.

        Version ``current`` (default: the last) is the function serving now; the others
        are kept as source and compiled by :meth:`revert` when chosen, in the namespace
        of the handler then serving. This is how a saved file brings versions back.
        """
        self._engine.restore_versions(what, versions, current)
        return self

    def __repr__(self) -> str:
        model = self._engine.model()
        state = "running" if self.created else "declared"
        return f"<rosNode {self.fullname} ({state}): {len(model.topics)} topics, " \
               f"{len(model.timers)} timers, {len(model.services)} services>"


def engine_of(node: rosNode) -> NodeEngine:
    """The engine of ``node``: how ipyros's own modules use a node (the user sees the DSL only)."""
    return node._engine


def _keeping() -> Any:
    """The files layer's saving, loading and exporting of nodes (see the comment above rosNode.save)."""
    from ..files import keeping  # noqa: PLC0415 - the one reach up: files/ is above node/, and saves nodes

    return keeping


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

    def __init__(self, engine: NodeEngine, role: str, chain: Optional[_Chain] = None) -> None:
        self._node = engine
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
            chain = _Chain(self._node.snapshot())
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
                self._node.restore(chain.snapshot, f"undo {done} ({self._role}.{call} failed)")
            except Exception as undo:  # noqa: BLE001 - said, with the error that matters first
                raise type(error)(f"{self._role}.{call} (call {len(chain.parts) + 1} of the chain) failed: {error}; "
                                  f"undoing the calls before it ({done}) failed too: {undo}") from None
            chain.open = False
            raise type(error)(f"{self._role}.{call} (call {len(chain.parts) + 1} of the chain) failed: {error}; "
                              f"the calls before it ({done}) were undone: the chain changed nothing") from None

    def _did(self, text: str) -> None:
        assert self._chain is not None
        self._chain.parts.append(text)
        self._node.record(f"{self._role}.{text}")

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
        resolved = node.resolve_as(role, topic, "topic")
        type_name, _ = msgtypes.resolve_message(msg_type)
        given = self._qos(qos, f"{role}.subscribe({topic!r})")
        if role == "reuse":
            check_reuse(node.model(), resolved, "subscribe")
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
        entry = TopicModel(topic, resolved, "subscribe", type_name, role, name_of(handler), qos=given.to_model())
        node.change(_replace_topic(entry), handlers, check=(entry,))
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
        resolved = node.resolve_as(self._role, topic, "topic")
        type_name, _ = msgtypes.resolve_message(msg_type)
        where = f"{self._role}.publish({topic!r})"
        given = self._qos(qos, where)
        if latch and given.durability == "volatile":
            raise DeclarationError(f"{where}: latch=True and a volatile qos contradict each other; "
                                   "drop one (latch=True is qos durability transient_local)")
        if self._role == "reuse":
            check_reuse(node.model(), resolved, "publish")
        entry = TopicModel(topic, resolved, "publish", type_name, self._role, None, bool(latch), given.to_model())
        node.change(_replace_topic(entry), check=(entry,))
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
        return self._node.dsl.create()

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
        resolved = node.resolve_as(role, topic, "topic")
        if node.model().topic(resolved, direction, role) is None:  # type: ignore[arg-type]
            raise NotDeclaredError(f"{node.name} has no {role}.{direction} of {resolved}")

        def edit(model: NodeModel) -> None:
            model.topics = [t for t in model.topics
                            if not (t.resolved == resolved and t.direction == direction and t.role == role)]

        drop = [planning.topic_slot(resolved)] if direction == "subscribe" and role == "new" else []
        node.change(edit, drop=drop)
        self._did(f"removed {direction} {resolved}")
        return self

    def service(self, name: str, srvType: Any = _UNSET, handler: Optional[Callable[..., Any]] = None,
                type: Any = _UNSET) -> "TopicHandler":  # noqa: A002,N803
        """Serve ``name`` with ``handler(request) -> response`` (new), or relay the basenode's (reuse)."""
        with self._part(f"service({name!r})") as link:
            return link._service(name, _one_type(srvType, type, name), handler)

    def _service(self, name: str, srv_type: Any, handler: Optional[Callable[..., Any]]) -> "TopicHandler":
        node, role = self._node, self._role
        resolved = node.resolve_as(role, name, "service")
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
        entry = ServiceModel(name, resolved, type_name, role, name_of(handler))

        def edit(model: NodeModel) -> None:
            model.services = [s for s in model.services if not (s.resolved == resolved and s.role == role)]
            model.services.append(entry)

        node.change(edit, handlers)
        self._did(f"service {resolved} [{type_name}]" + (f" -> {entry.handler}" if handler else ""))
        return self


class NodeParams(MutableMapping):
    """The node's private (``~name``) parameters: live on the parameter server (ROS 2: the node) once created."""

    def __init__(self, engine: NodeEngine) -> None:
        self._node = engine

    def _key(self, key: str) -> str:
        if not isinstance(key, str) or key.startswith(("/", "~")):
            raise DeclarationError(f"parameter key {key!r}: give the private name without ~ or /, e.g. 'gain'")
        return names.check_param_key(key, f"{self._node.name}.params")

    def __getitem__(self, key: str) -> Any:
        return self._node.read_param(self._key(key))

    def __setitem__(self, key: str, value: Any) -> None:
        self._node.set_param(self._key(key), value)

    def __delitem__(self, key: str) -> None:
        self._node.delete_param(self._key(key))

    def __iter__(self) -> Iterator[str]:
        return iter(self._node.model().params)

    def __len__(self) -> int:
        return len(self._node.model().params)

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
