"""A node's own parameters (``nd.params``) and the functions ``on_param`` calls when someone else sets one.

Before ``create()`` a parameter is only declared (in the model); once the node runs it lives where
its ROS keeps it (ROS 1: the parameter server; ROS 2: the node itself), by its global name
``/ns/node/key``. What the session sets itself is not news for ``on_param``; what a tuning tool,
``rosparam set`` or ``ros2 param set`` sets is (the backend's ``watch_param``).
"""

from __future__ import annotations

from typing import Any, Callable, Optional, Protocol

from ..core.errors import NotDeclaredError
from ..core.versions import name_of

__all__ = ["NodeParameters"]


class ParamOwner(Protocol):
    """What a node's parameters need of it (its :class:`~ipyros.node.engine.NodeEngine`)."""

    @property
    def name(self) -> str: ...
    @property
    def called(self) -> str: ...
    created: bool
    session: Any

    def resolve(self, name: str, kind: str = "topic") -> str: ...
    def declared_params(self) -> dict[str, Any]: ...  # the model's own dict: edited in place under the node's lock
    def record(self, change: str) -> None: ...
    def complain(self, text: str) -> None: ...


class NodeParameters:
    """The parameters of one node, live or declared, and its ``on_param`` functions and their watches."""

    def __init__(self, node: ParamOwner, lock: Any) -> None:
        self._node = node
        self._lock = lock  # the node's: a parameter and the model it is declared in change together
        self._handlers: dict[str, Callable[[Any], Any]] = {}  # key → on_param's function
        self._watches: dict[str, Any] = {}  # key → the backend's watch, while the node runs
        self._seen: dict[str, Any] = {}  # key → the last value known (set here, or told)

    def _name(self, key: str) -> str:
        return self._node.resolve("~" + key, "parameter")

    @property
    def _backend(self) -> Any:
        return self._node.session.backend

    def handlers(self) -> dict[str, Callable[[Any], Any]]:
        """The functions ``on_param`` calls, by parameter key."""
        with self._lock:
            return dict(self._handlers)

    def get(self, key: str) -> Any:
        return self._backend.get_param(self._name(key))

    def live(self) -> tuple[tuple[str, str], ...]:
        """``(~key, repr(value))`` of each declared parameter the node has now, for its status."""
        return tuple((f"~{key}", repr(self.get(key))) for key in self._node.declared_params()
                     if self._backend.has_param(self._name(key)))

    def read(self, key: str) -> Any:
        """The value: the live one once created, else the declared one; a KeyError that says which parameters there
        are if it has none of that name."""
        if self._node.created:
            if not self._backend.has_param(self._name(key)):
                raise self._missing(key)
            return self.get(key)
        declared = self._node.declared_params()
        if key not in declared:
            raise self._missing(key)
        return declared[key]

    def set(self, key: str, value: Any) -> None:
        node, name = self._node, self._name(key)
        self._backend.check_param(name, value)
        with self._lock:
            if node.created:
                node.session.require_graph(f"{node.called}.params[{key!r}] = ...")
                self._seen[key] = value  # set here: not news for on_param
                self._backend.set_param(name, value)
            node.declared_params()[key] = value
            node.record(f"params[{key!r}] = {value!r}")

    def delete(self, key: str) -> None:
        name = self._name(key)
        with self._lock:
            declared = self._node.declared_params()
            live = self._node.created and self._backend.has_param(name)
            if key not in declared and not live:
                raise self._missing(key)
            if live:
                self._backend.delete_param(name)
            declared.pop(key, None)

    def _missing(self, key: str) -> KeyError:
        """A KeyError, as a mapping raises, that says which parameters there are."""
        have = ", ".join(repr(k) for k in self._node.declared_params()) or "none yet"
        return KeyError(f"{self._node.name} has no parameter {key!r} (it has {have}); "
                        f"set one with {self._node.called}.params[{key!r}] = value")

    def on_param(self, key: str, handler: Optional[Callable[[Any], Any]]) -> None:
        """Call ``handler(value)`` when someone else sets parameter ``key``; ``None`` stops it."""
        with self._lock:
            self._on_param(key, handler)

    def _on_param(self, key: str, handler: Optional[Callable[[Any], Any]]) -> None:
        node = self._node
        watch = self._watches.pop(key, None)
        if watch is not None:
            watch.close()
        if handler is None:
            self._handlers.pop(key, None)
            node.record(f"on_param({key!r}, None)")
            return
        if key not in node.declared_params():
            raise NotDeclaredError(f"{node.name} has no parameter {key!r} to watch; give it a value first, "
                                   f"{node.called}.params[{key!r}] = ..., then {node.called}.on_param({key!r}, fn)")
        self._handlers[key] = handler
        if node.created:
            self._watch(key)
        node.record(f"on_param({key!r}, {name_of(handler) or 'handler'})")

    def start(self) -> None:
        """The node starts: its parameters set where its ROS keeps them, and watched for ``on_param``."""
        self.set_all()
        for key in self._handlers:
            self._watch(key)

    def set_all(self) -> int:
        """Set every declared parameter where the ROS keeps them (at start, and after a ROS 1 master restart)."""
        with self._lock:
            declared = dict(self._node.declared_params())
        for key, value in declared.items():
            self._backend.set_param(self._name(key), value)
        return len(declared)

    def stop(self) -> None:
        """The node stops: the watches end (the functions stay, for the next ``create()``)."""
        for watch in self._watches.values():
            watch.close()
        self._watches.clear()

    def _watch(self, key: str) -> None:
        self._seen[key] = self._node.declared_params().get(key)
        self._watches[key] = self._backend.watch_param(self._name(key), lambda value: self._set(key, value))

    def _set(self, key: str, value: Any) -> None:
        """A parameter was set (told by the backend, from whatever thread): the handler runs if it changed."""
        if value == self._seen.get(key):  # this session set it, or it was set to what it was
            return
        self._seen[key] = value
        handler = self._handlers.get(key)
        if handler is None:
            return
        try:
            handler(value)
        except Exception as error:  # noqa: BLE001 - a handler's crash never takes the node down
            self._node.complain(f"on_param({key!r}) handler {name_of(handler) or ''} raised "
                                f"{type(error).__name__}: {error} (the parameter is {value!r}; the node runs on)")
