"""Declarations: ``node.new`` and ``node.reuse`` (topics, services and actions, chained), and ``node.params``.

A chain (``nd.new.subscribe(...).publish(...)``) is one change: all of it applies, or
none, and the error says which call failed. This module spells the calls (chains, the paper's
attribute spelling ``nd.reuse.publish.cmd_vel(Twist)``, what a chain shows at the prompt);
what each one declares, and its checks, are :mod:`ipyros.node.declaring`'s.
"""

from __future__ import annotations

import contextlib
import inspect
import weakref
from collections.abc import MutableMapping
from typing import Any, Callable, Iterator, Optional

from ..core import names
from ..core.errors import DeclarationError, IpyrosError, MessageTypeError
from ..core.graph import actions_of
from ..node import declaring
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
    """``node.new`` or ``node.reuse``: declares topics, services and actions, chainable; a chain is all or nothing.

    It spells the calls; what each declares, and the checks, are :mod:`ipyros.node.declaring`'s.
    """

    def __init__(self, node: Any, role: str, chain: Optional[_Chain] = None) -> None:
        self._dsl = node  # the rosNode: .create() ends a chain with it
        self._node: NodeEngine = node._engine
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
            link = TopicHandler(self._dsl, self._role, chain)
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

    def _did(self, text: str) -> "TopicHandler":
        """The chain goes on from this link; ``text`` (what the call declared) is listed if a later call fails."""
        assert self._chain is not None
        self._chain.parts.append(text)
        return self

    def subscribe(self, topic: str, handler: Optional[Callable[..., Any]] = None, msgType: Any = UNSET,
                  type: Any = UNSET, qos: Any = None) -> "TopicHandler":  # noqa: A002,N803 - the paper's names
        """Subscribe ``handler(msg)`` to ``topic``; declaring it again swaps the handler live.

        ``qos``: a profile name (``"sensor_data"``, ``"best_effort"``, ``"transient_local"``, ...),
        a depth, or a dict of depth, reliability, durability (see :mod:`ipyros.core.qos`).
        """
        with self._part(f"subscribe({topic!r})") as link:
            return link._did(declaring.subscribe(self._node, self._role, topic, handler,
                                                 one_type(msgType, type, topic), qos))

    def publish(self, topic: str, msgType: Any = UNSET, type: Any = UNSET,
                latch: bool = False, qos: Any = None) -> "TopicHandler":  # noqa: A002,N803 - the paper's names
        """Publish ``topic``; ``node.write(topic, msg)`` sends on it.

        ``latch``: a subscriber that connects later gets the last message (on ROS 2,
        transient-local durability); ``qos`` as for :meth:`subscribe`.
        """
        with self._part(f"publish({topic!r})") as link:
            return link._did(declaring.publish(self._node, self._role, topic, one_type(msgType, type, topic),
                                               latch, qos))

    def create(self) -> Any:
        """Create the node, so a declaration chain can end with ``.create()`` (which ends the chain)."""
        if self._chain is not None:
            self._chain.open = False
        return self._dsl.create()

    def unsubscribe(self, topic: str) -> "TopicHandler":
        """Drop this role's subscription to ``topic``."""
        with self._part(f"unsubscribe({topic!r})") as link:
            return link._did(declaring.drop(self._node, self._role, topic, "subscribe"))

    def unpublish(self, topic: str) -> "TopicHandler":
        """Drop this role's publication of ``topic``."""
        with self._part(f"unpublish({topic!r})") as link:
            return link._did(declaring.drop(self._node, self._role, topic, "publish"))

    def service(self, name: str, srvType: Any = UNSET, handler: Optional[Callable[..., Any]] = None,
                type: Any = UNSET) -> "TopicHandler":  # noqa: A002,N803
        """Serve ``name`` with ``handler(request) -> response`` (new), or relay the basenode's (reuse)."""
        with self._part(f"service({name!r})") as link:
            return link._did(declaring.serve(self._node, self._role, "service", name, one_type(srvType, type, name),
                                             handler))

    def action(self, name: str, type: Any = UNSET, handler: Optional[Callable[..., Any]] = None,
               actionType: Any = UNSET) -> "TopicHandler":  # noqa: A002,N803 - type= as for topics
        """Serve action ``name`` with ``handler(goal[, action]) -> result`` (new), or relay the basenode's (reuse).

        The handler runs on a thread of its own for each goal; ``action.feedback(msg)``
        sends feedback, ``action.cancelled`` tells of a cancel, and on a node that also
        reuses the action ``action.forward(goal)`` hands the goal to the basenode's server
        (see :mod:`ipyros.core.actions`). Declaring it again swaps the handler live.
        """
        with self._part(f"action({name!r})") as link:
            return link._did(declaring.serve(self._node, self._role, "action", name,
                                             one_type(actionType, type, name), handler))


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
        return self._node.params.read(self._key(key))

    def __setitem__(self, key: str, value: Any) -> None:
        self._node.params.set(self._key(key), value)

    def __delitem__(self, key: str) -> None:
        self._node.params.delete(self._key(key))

    def __iter__(self) -> Iterator[str]:
        return iter(self._node.model().params)

    def __len__(self) -> int:
        return len(self._node.model().params)

    def __repr__(self) -> str:
        return f"<{self._node.name}.params {dict(self.items())!r}>"


def one_type(msg_type: Any, type_: Any, name: str) -> Any:
    if msg_type is not UNSET and type_ is not UNSET and msg_type is not type_ and msg_type != type_:
        raise MessageTypeError(f"{name}: msgType={msg_type!r} and type={type_!r} disagree; give just one")
    chosen = msg_type if msg_type is not UNSET else type_
    if chosen is UNSET:
        raise MessageTypeError(f"{name}: no message type given; add msgType=... e.g. msgType=Twist "
                               "or msgType='geometry_msgs/Twist'")
    return chosen
