"""Declarations: ``node.new`` and ``node.reuse`` (topics, services and actions, chained), and ``node.params``.

A chain (``nd.new.subscribe(...).publish(...)``) is one change: all of it applies, or
none, and the error says which call failed. Each call validates its input and hands the
node's :class:`~ipyros.node.engine.NodeEngine` an edit of the model.
"""

from __future__ import annotations

import contextlib
import importlib.util
import inspect
import re
import weakref
from collections.abc import MutableMapping
from typing import Any, Callable, Iterator, Optional

from ..core import msgtypes, names, plan as planning, qos as qos_mod
from ..core.errors import (
    DeclarationError,
    HandlerError,
    IpyrosError,
    MessageTypeError,
    NotDeclaredError,
    TopicTypeConflict,
)
from ..core.graph import actions_of
from ..core.model import ActionModel, NodeModel, ServiceModel, TopicModel
from ..core.remapping import check_reuse
from ..core.slots import call_arity
from ..core.versions import name_of
from ..node.engine import NodeEngine

__all__ = ["NodeParams", "TopicHandler", "UNSET", "end_chains", "one_type"]

#: An argument not given (``None`` may be meant: a subscription without handler).
UNSET: Any = object()


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


class _Spelled:
    """A declaring method that the paper's spelling reaches too: ``nd.reuse.publish.cmd_vel(Twist)`` is
    ``nd.reuse.publish("cmd_vel", Twist)``, ``nd.reuse.subscribe.turtle1.pose(Pose)`` names ``turtle1/pose``.

    A descriptor: ``nd.new.publish`` is a :class:`_Name` with no name yet, which calls the method
    as it is; each attribute after it adds a part of the name. TAB after the dot offers the names
    the graph knows there (the extension's cached graph: never a wait on the network).
    """

    def __init__(self, method: Callable[..., Any], kind: str) -> None:
        self.method, self.kind = method, kind
        self.__doc__ = method.__doc__

    def __get__(self, handler: Optional["TopicHandler"], owner: type) -> Any:
        if handler is None:
            return self.method
        return _Name(handler, self.method, self.kind, ())


class _Name:
    """``nd.reuse.subscribe.turtle1.pose``: a name being spelled as attributes; calling it declares it."""

    def __init__(self, handler: "TopicHandler", method: Callable[..., Any], kind: str, parts: tuple[str, ...]) -> None:
        self._handler, self._method, self._kind, self._parts = handler, method, kind, parts
        self.__doc__ = method.__doc__
        parameters = list(inspect.signature(method).parameters.values())[1 if not parts else 2:]
        self.__signature__ = inspect.Signature(parameters)

    def __call__(self, *args: Any, **kwargs: Any) -> "TopicHandler":
        if not self._parts:
            return self._method(self._handler, *args, **kwargs)
        return self._method(self._handler, "/".join(self._parts), *args, **kwargs)

    def __getattr__(self, part: str) -> "_Name":
        if part.startswith("__"):
            raise AttributeError(part)
        return _Name(self._handler, self._method, self._kind, self._parts + (part,))

    def __dir__(self) -> list[str]:
        """The next parts of the names the graph has here (relative to the node's namespace), for TAB."""
        node = self._handler._node
        graph = node.session.known_graph()
        known = {"topic": graph.topic_names, "service": tuple(graph.services),
                 "action": tuple(a.name for a in actions_of(graph))}[self._kind]
        base = node.resolve_as(self._handler._role, "x", "topic")[:-1]  # the namespace names resolve in
        prefix = base + "".join(part + "/" for part in self._parts)
        return sorted({name[len(prefix):].split("/")[0] for name in known
                       if name.startswith(prefix) and name[len(prefix):].split("/")[0].isidentifier()})

    def __repr__(self) -> str:
        spelled = "." + ".".join(self._parts) if self._parts else ""
        return f"<{self._handler._node.name}.{self._handler._role}.{self._method.__name__}{spelled}: call it to declare>"


class TopicHandler:
    """``node.new`` or ``node.reuse``: declares topics, services and actions, chainable; a chain is all or nothing."""

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
            "subscribe(), publish(), service(), action(), unsubscribe(), unpublish()"
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

    def subscribe(self, topic: str, handler: Optional[Callable[..., Any]] = None, msgType: Any = UNSET,
                  type: Any = UNSET, qos: Any = None) -> "TopicHandler":  # noqa: A002,N803 - the paper's names
        """Subscribe ``handler(msg)`` to ``topic``; declaring it again swaps the handler live.

        ``qos``: a profile name (``"sensor_data"``, ``"best_effort"``, ``"transient_local"``, ...),
        a depth, or a dict of depth, reliability, durability (see :mod:`ipyros.core.qos`).
        """
        with self._part(f"subscribe({topic!r})") as link:
            return link._subscribe(topic, handler, one_type(msgType, type, topic), qos)

    def _subscribe(self, topic: str, handler: Optional[Callable[..., Any]], msg_type: Any, qos: Any) -> "TopicHandler":
        node, role = self._node, self._role
        resolved = node.resolve_as(role, topic, "topic")
        type_name = self._type_name(msg_type, relayed=role == "reuse" and handler is None)
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
        before = node.model().topic(resolved, "subscribe", role)  # declared again: a swap, said as one
        node.change(_replace_topic(entry), handlers, check=(entry,))
        if before is not None and before.type == type_name and before.handler and handler is not None:
            self._did(f"subscribe {resolved}: handler {before.handler} → {entry.handler}")
        else:
            self._did(f"subscribe {resolved} [{type_name}]" + (f" -> {entry.handler}" if handler else ""))
        return self

    def publish(self, topic: str, msgType: Any = UNSET, type: Any = UNSET,
                latch: bool = False, qos: Any = None) -> "TopicHandler":  # noqa: A002,N803 - the paper's names
        """Publish ``topic``; ``node.write(topic, msg)`` sends on it.

        ``latch``: a subscriber that connects later gets the last message (on ROS 2,
        transient-local durability); ``qos`` as for :meth:`subscribe`.
        """
        with self._part(f"publish({topic!r})") as link:
            return link._publish(topic, one_type(msgType, type, topic), latch, qos)

    def _publish(self, topic: str, msg_type: Any, latch: bool, qos: Any) -> "TopicHandler":
        node = self._node
        resolved = node.resolve_as(self._role, topic, "topic")
        type_name = self._type_name(msg_type, relayed=self._role == "reuse")
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

    def _type_name(self, msg_type: Any, relayed: bool) -> str:
        """The declared type's name; a type this Python cannot import is taken, as ``pkg/Type``, only for a relay: a
        handler or a publisher needs its class, a relay does not (ROS 1 relays bytes of any type) or gets it from
        the basenode before it opens (ROS 2: :func:`~ipyros.node.wrapping.learn_relayed_types`)."""
        try:
            return msgtypes.resolve_message(msg_type)[0]
        except MessageTypeError:
            if not (relayed and isinstance(msg_type, str) and re.fullmatch(r"\w+/(msg/)?\w+", msg_type.strip())):
                raise
            package, _, name = msg_type.strip().partition("/")
            if not self._node.session.backend.relays_any_type and importlib.util.find_spec(package) is not None:
                raise  # the package is here, the name is wrong: the error says which names it has
            return f"{package}/{name.rsplit('/', 1)[-1]}"

    def _qos(self, value: Any, where: str) -> qos_mod.Qos:
        """``qos=`` checked; refused on reuse, whose relays take the QoS of what they relay."""
        if value is not None and self._role == "reuse":
            raise DeclarationError(f"{where}: a reuse relay takes the QoS of the publishers it relays and "
                                   "takes no qos=; give qos= to new.subscribe or new.publish")
        return qos_mod.parse(value, where)

    def create(self) -> Any:
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

    def service(self, name: str, srvType: Any = UNSET, handler: Optional[Callable[..., Any]] = None,
                type: Any = UNSET) -> "TopicHandler":  # noqa: A002,N803
        """Serve ``name`` with ``handler(request) -> response`` (new), or relay the basenode's (reuse)."""
        with self._part(f"service({name!r})") as link:
            return link._service(name, one_type(srvType, type, name), handler)

    def _service(self, name: str, srv_type: Any, handler: Optional[Callable[..., Any]]) -> "TopicHandler":
        return self._served("service", name, msgtypes.resolve_service(srv_type)[0], handler)


    def action(self, name: str, type: Any = UNSET, handler: Optional[Callable[..., Any]] = None,
               actionType: Any = UNSET) -> "TopicHandler":  # noqa: A002,N803 - type= as for topics
        """Serve action ``name`` with ``handler(goal[, action]) -> result`` (new), or relay the basenode's (reuse).

        The handler runs on a thread of its own for each goal; ``action.feedback(msg)``
        sends feedback, ``action.cancelled`` tells of a cancel, and on a node that also
        reuses the action ``action.forward(goal)`` hands the goal to the basenode's server
        (see :mod:`ipyros.core.actions`). Declaring it again swaps the handler live.
        """
        with self._part(f"action({name!r})") as link:
            return link._action(name, one_type(actionType, type, name), handler)

    def _action(self, name: str, action_type: Any, handler: Optional[Callable[..., Any]]) -> "TopicHandler":
        return self._served("action", name, msgtypes.resolve_action(action_type)[0], handler)

    #: What each served kind is called with, returns, and how the reuse of it is changed instead (for its errors).
    _SERVED = {"service": ("called with each request, returns the response", "to answer it yourself"),
               "action": ("called with each goal, returns the result", "to serve or change its goals")}

    def _served(self, kind: str, name: str, type_name: str, handler: Optional[Callable[..., Any]]) -> "TopicHandler":
        """A service or an action: served by ``handler`` (new) or relayed from the basenode (reuse).

        Both are a name, a type and a handler slot; declared again they swap the handler live, and a
        ``new`` and a ``reuse`` of one name must agree on its type.
        """
        node, role = self._node, self._role
        resolved = node.resolve_as(role, name, kind)
        slot = (planning.service_slot if kind == "service" else planning.action_slot)(resolved)
        does, instead = self._SERVED[kind]
        handlers = {}
        if role == "new":
            if handler is None:
                raise HandlerError(f"new.{kind}({name!r}) needs handler=...: {does}")
            handlers[slot] = (handler, call_arity(handler, kind, f"{node.name} {resolved}"))
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

        node.change(edit, handlers)
        self._did(f"{kind} {resolved} [{type_name}]" + (f" -> {entry.handler}" if handler else ""))
        return self


for _method, _kind in (("subscribe", "topic"), ("publish", "topic"), ("service", "service"), ("action", "action")):
    setattr(TopicHandler, _method, _Spelled(getattr(TopicHandler, _method), _kind))


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


def one_type(msg_type: Any, type_: Any, name: str) -> Any:
    if msg_type is not UNSET and type_ is not UNSET and msg_type is not type_ and msg_type != type_:
        raise MessageTypeError(f"{name}: msgType={msg_type!r} and type={type_!r} disagree; give just one")
    chosen = msg_type if msg_type is not UNSET else type_
    if chosen is UNSET:
        raise MessageTypeError(f"{name}: no message type given; add msgType=... e.g. msgType=Twist "
                               "or msgType='geometry_msgs/Twist'")
    return chosen
