"""Listening to and publishing on live topics from the prompt, through small DSL nodes.

``%echo``, ``%topics --hz`` and ``%pub`` need what ``rostopic`` needs: a subscriber for a
moment, a publisher for one message. They get it from ordinary DSL nodes (so rospy stays
behind :mod:`ipyros.ros1.runtime`), named ``ipyros_<purpose>_<pid>``:

* :class:`Echo` and :func:`measure_rates` create a node, subscribe, and shut it down
  when done, so nothing is left subscribed;
* :class:`PromptPublisher` keeps one node whose publications are *latched* and stay
  advertised until :meth:`~PromptPublisher.close`: a message published from the prompt
  reaches subscribers that are still connecting (there is no waiting for them), and
  later ones, as with ``rostopic pub``. A topic that one of the session's own nodes
  already publishes is written through that node instead, so its publisher does not
  become latched behind its back.

All of a session's DSL nodes share the process's one ROS node; if one of these is the
first node created, that ROS node takes its name (see :mod:`ipyros.session`).
"""

from __future__ import annotations

import os
import re
import queue
import statistics
import time
from dataclasses import dataclass
from typing import Any, Mapping, Optional

from . import msgtypes
from .dsl import rosNode
from .errors import MessageTypeError
from .session import current


def tool_name(purpose: str) -> str:
    """The DSL node name of a probe: unique on the master, recognisable in ``rosnode list``."""
    return f"ipyros_{purpose}_{os.getpid()}"


def is_tool(name: str) -> bool:
    """Whether ``name`` is a probe's (of any ipyros session): not a node the user made."""
    return re.fullmatch(r"ipyros_[a-z]+_\d+", name.rsplit("/", 1)[-1]) is not None


class Echo:
    """Subscribe to ``topic`` while in a ``with`` block; :meth:`get` returns the messages in order.

    ``type_name`` is the topic's type (``pkg/Type``); its Python class must be installed.
    """

    def __init__(self, topic: str, type_name: str) -> None:
        self.topic = topic
        self._messages: "queue.SimpleQueue[Any]" = queue.SimpleQueue()
        self.node = rosNode(tool_name("echo"))
        self.node.new.subscribe(topic, handler=self._received, msgType=type_name)

    def _received(self, msg: Any) -> None:
        self._messages.put(msg)

    def get(self, timeout: float) -> Optional[Any]:
        """The next message, or None if none arrives within ``timeout`` seconds."""
        try:
            return self._messages.get(timeout=timeout)
        except queue.Empty:
            return None

    def __enter__(self) -> "Echo":
        self.node.create()
        return self

    def __exit__(self, *exc: Any) -> None:
        self.node.shutdown()


@dataclass(frozen=True)
class Rate:
    """What arrived on one topic during a measurement."""

    count: int
    hz: Optional[float]  # None with fewer than two messages: no interval to measure
    min_s: float = 0.0  # the shortest, the longest interval between two messages, and their spread
    max_s: float = 0.0
    std_s: float = 0.0


class _Stamps:
    """A handler that notes when each message arrives."""

    def __init__(self) -> None:
        self.times: list[float] = []

    def __call__(self, msg: Any) -> None:
        self.times.append(time.monotonic())

    def rate(self) -> Rate:
        times = list(self.times)
        if len(times) < 2 or times[-1] <= times[0]:
            return Rate(len(times), None)
        gaps = [b - a for a, b in zip(times, times[1:])]
        return Rate(len(times), (len(times) - 1) / (times[-1] - times[0]), min(gaps), max(gaps),
                    statistics.pstdev(gaps))


def measure_rates(topics: Mapping[str, str], window: float) -> dict[str, Optional[Rate]]:
    """Listen to ``topics`` ({name: type}) for ``window`` seconds; what arrived on each.

    The rate is measured between the first and the last message, so the time it takes
    to connect does not count. A topic whose message class is not installed here cannot
    be listened to: None. Ctrl-C stops the measurement (KeyboardInterrupt propagates);
    the node is shut down either way.
    """
    node = rosNode(tool_name("hz"))
    stamps: dict[str, _Stamps] = {}
    for topic, type_name in topics.items():
        try:
            msgtypes.resolve_message(type_name)
        except MessageTypeError:
            continue
        stamps[topic] = _Stamps()
        node.new.subscribe(topic, handler=stamps[topic], msgType=type_name)
    if not stamps:
        return {topic: None for topic in topics}
    try:
        node.create()
        time.sleep(window)  # the measurement itself: note what arrives in the window
    finally:
        node.shutdown()
    return {t: stamps[t].rate() if t in stamps else None for t in topics}


class PromptPublisher:
    """Publishes single messages from the prompt (see the module docstring for how)."""

    def __init__(self) -> None:
        self._node: Optional[rosNode] = None

    def publish(self, topic: str, type_name: str, msg: Any) -> str:
        """Send ``msg`` on ``topic`` (a global name) and return the DSL node that sent it."""
        owner = self._owner(topic, type_name)
        if owner is not None:
            owner.write(topic, msg)
            return owner.name
        node = self._node
        if node is None or not node.created:
            node = self._node = rosNode(tool_name("pub"))
        declared = node.model().topic(topic, "publish", "new")
        if declared is None or declared.type != type_name:
            node.new.publish(topic, msgType=type_name, latch=True)
        node.create()
        node.write(topic, msg)
        return node.name

    def _owner(self, topic: str, type_name: str) -> Optional[rosNode]:
        """A running node of the session (not ours) that publishes ``topic`` with that type."""
        for node in list(current().nodes.values()):
            if node is self._node or not node.created:
                continue
            model = node.model()
            declared = model.topic(topic, "publish", "new")
            if declared is not None and declared.type == type_name:
                return node
        return None

    def close(self) -> None:
        """Stop advertising everything published so far."""
        if self._node is not None:
            self._node.shutdown()
            self._node = None
