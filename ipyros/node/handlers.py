"""What a name is on one node, the function that serves it, and its versions: what ``%handler``, ``%edit``,
``%revert`` and ``nd.versions`` ask of a node (a part of :class:`~ipyros.node.engine.NodeEngine`).

A name is found as a :class:`~ipyros.node.targets.HandlerTarget` (a topic, a timer, a service or an action with
a handler, or a topic the node only relays, which a handler can take over); swapping its function declares it
again exactly as it is (:func:`ipyros.node.declaring.redeclare`), so a swap is the DSL's own live change; a
version brought back is declared again the same way, and the versions a saved file holds are restored as they
were.
"""

from __future__ import annotations

import threading
from typing import Any, Callable, Optional, Protocol

from ..core.errors import NotDeclaredError
from ..core.records import Versions
from . import declaring
from .targets import HandlerTarget, find_target, relayed_target
from .versions import HandlerVersions, parse_versions

__all__ = ["HandlerEdits"]


class EditedNode(declaring.DeclaringNode, Protocol):
    """What editing its handlers needs of a node (its :class:`~ipyros.node.engine.NodeEngine`)."""

    @property
    def called(self) -> str: ...
    def handler(self, name: str) -> Optional[Callable[..., Any]]: ...


class HandlerEdits:
    """The handlers of one node as ``%handler`` and ``nd.revert`` change them (see the module's docstring)."""

    def __init__(self, node: EditedNode, versions: HandlerVersions, lock: threading.RLock) -> None:
        self._node, self._versions, self._lock = node, versions, lock

    def find_target(self, name: str) -> HandlerTarget:
        """What ``name`` (a topic, a timer name, a service or an action) is on this node, if it has a handler."""
        node = self._node
        return find_target(node.model(), node.resolve, name, node.called)

    def relayed_target(self, name: str) -> Optional[HandlerTarget]:
        """``name`` as a topic this node only relays, as a target a handler can take over; None if it is not one."""
        return relayed_target(self._node.model(), self._node.resolve, name)

    def current_handler(self, target: HandlerTarget) -> Callable[..., Any]:
        """The function that serves ``target`` now."""
        handler = self._node.handler(target.name)
        if handler is None:  # the node changed since find_target
            raise NotDeclaredError(f"{self._node.name} has no handler for {target.label} any more")
        return handler

    def redeclare(self, target: HandlerTarget, handler: Callable[..., Any]) -> None:
        """Declare ``target`` again exactly as it is, but served by ``handler`` (a live swap, as the DSL does it)."""
        declaring.redeclare(self._node, target, handler)

    def versions(self, what: str) -> Versions:
        """Every function the handler of ``what`` was given, oldest first, and the one serving now."""
        target = self.find_target(what)
        with self._lock:
            found, current = self._versions.of(target.slot)
            return Versions(f"{self._node.name} {target.label}", tuple(found), current)

    def revert(self, what: str, version: int) -> None:
        """Bring version ``version`` of the handler of ``what`` back (declared again, as a swap is)."""
        target = self.find_target(what)
        node = self._node
        with self._lock:
            chosen = self._versions.choose(
                target.slot, version, f"{node.name} {target.label}", f"{node.called}.versions({what!r})",
                lambda: getattr(self.current_handler(target), "__globals__", {}))
            self._versions.reverting = version
            try:
                assert chosen.function is not None
                self.redeclare(target, chosen.function)
            finally:
                self._versions.reverting = None

    def restore(self, what: str, versions: list[tuple[str, str]], current: Optional[int]) -> None:
        """The versions a saved file holds for ``what``, as they were (the current one is the function serving)."""
        target = self.find_target(what)
        restored, current = parse_versions(what, versions, current)
        with self._lock:
            restored[current - 1].function = self.current_handler(target)
            self._versions.set(target.slot, restored, current)
