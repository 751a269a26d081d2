"""What a node sends by hand: ``nd.write(topic, msg)``, a message sent on a guarded output (``%pub``, an e-stop),
and goals to action servers (``nd.send_goal``).

A write goes out through the node's open publication of that topic (its own, an output of its
basenode it took over, or its basenode's input it feeds), found once and kept until the node
changes. Every message sent on a guarded output passes its guard first: the endpoint holds the
gate (:mod:`ipyros.node.guards`). Within :func:`writes_recorded` (``%try``) a write is recorded
for the calling thread instead of sent.
"""

from __future__ import annotations

import contextlib
from contextvars import ContextVar
from typing import Any, Callable, Iterator, Optional, Protocol

from ..core import msgtypes, plan as planning
from ..core.errors import MessageTypeError, NodeStateError, NotDeclaredError
from ..core.model import NodeModel
from .endpoints import output_of, publication_of

__all__ = ["Writing", "writes_recorded"]

#: Set within :func:`writes_recorded`: what ``write`` is asked to send, handed over instead of sent.
_recording: ContextVar[Optional[Callable[[Any, str, Any], None]]] = ContextVar("ipyros_recording", default=None)


@contextlib.contextmanager
def writes_recorded(record: Callable[[Any, str, Any], None]) -> Iterator[None]:
    """Within the block, ``write(topic, msg)`` calls made by the calling thread (not by any other) are handed to
    ``record(engine, topic, msg)`` and not sent: how ``%try`` runs a handler without it publishing."""
    token = _recording.set(record)
    try:
        yield
    finally:
        _recording.reset(token)


class WritingNode(Protocol):
    """What writing needs of a node (its :class:`~ipyros.node.engine.NodeEngine`)."""

    @property
    def name(self) -> str: ...
    @property
    def called(self) -> str: ...
    created: bool
    session: Any

    def resolve(self, name: str, kind: str = "topic") -> str: ...
    def declared_type(self, resolved: str) -> Optional[str]: ...
    def model(self) -> NodeModel: ...
    def live(self) -> dict[Any, Any]: ...  # its open endpoints, by spec (a copy)


class Writing:
    """The writes of one node (see the module's docstring)."""

    def __init__(self, node: WritingNode) -> None:
        self._node = node
        self._writers: dict[str, tuple[Any, str]] = {}  # topic as typed → (publication, type)

    def forget(self) -> None:
        """The node changed (or stopped): find each publication again at the next write."""
        self._writers.clear()

    def writer(self, topic: str) -> tuple[Any, str]:
        """The publication ``write(topic, ...)`` sends through, and the type declared for it."""
        found = self._writers.get(topic)
        if found is not None:
            return found
        node = self._node
        resolved = node.resolve(topic)
        target = planning.write_target(node.model(), resolved)
        if target is None:
            raise NotDeclaredError(f"{node.name} does not publish {resolved}; declare it first: "
                                   f"{node.called}.new.publish(topic={topic!r}, msgType=...)")
        if not node.created:
            raise NodeStateError(f"{node.name} is not running; call {node.called}.create() before write()")
        found = self._writers[topic] = (publication_of(node.live(), target), node.declared_type(resolved) or "")
        return found

    def write(self, topic: str, msg: Any) -> None:
        """Publish ``msg`` on ``topic`` (see :meth:`rosNode.write <ipyros.dsl.rosnode.rosNode.write>`)."""
        record = _recording.get()
        if record is not None:  # a handler being tried: what it would send is recorded, not sent
            record(self._node, topic, msg)
            return
        publication, type_name = self.writer(topic)
        got = msgtypes.type_name(msg)  # a class of the right type is refused by the publication, in its words
        if got != type_name:
            got = got or type(msg).__name__
            raise MessageTypeError(f"{topic} carries {type_name}, not {got}; "
                                   f"build a {type_name.split('/')[1]}() and write that")
        publication.write(msg)

    def send(self, topic: str, msg: Any) -> bool:
        """Send ``msg`` on the output ``topic`` (a global name) through its guard, whatever the output is (a
        publication, a relay of the basenode's): what ``%pub`` and an e-stop do; False if the node has none."""
        for spec, endpoint in self._node.live().items():
            if output_of(spec) == topic:
                (getattr(endpoint, "send", None) or endpoint.write)(msg)
                return True
        return False

    def send_goal(self, name: str, goal: Any, action_type: Any, feedback: Optional[Callable[[Any], None]],
                  timeout: float) -> Any:
        """Send a goal to action ``name`` (see :meth:`rosNode.send_goal <ipyros.dsl.rosnode.rosNode.send_goal>`)."""
        node = self._node
        if not node.created:
            raise NodeStateError(f"{node.name} is not running; call {node.called}.create() first")
        return node.session.send_goal(node.resolve(name, "action"), goal, action_type, feedback, timeout)
