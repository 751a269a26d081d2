"""Listening to and publishing on live topics from the prompt, through small DSL nodes.

``%echo``, ``%topics --hz`` and ``%pub`` need what ``rostopic`` needs: a subscriber for a
moment, a publisher for one message. They get it from ordinary DSL nodes (so rospy stays
behind :mod:`ipyros.ros1.runtime`), named ``ipyros_<purpose>_<pid>``:

* :class:`Echo` and :func:`measure_rates` create a node, subscribe, and shut it down
  when done, so nothing is left subscribed;
* :class:`PromptPublisher` keeps one node whose publications stay advertised until
  :meth:`~PromptPublisher.close`: a message from the prompt waits a moment for the
  subscribers the graph knows to connect, then goes out once, as ``rostopic pub -1`` and
  ``ros2 topic pub --once`` send it (latched only when asked: ``%pub --latch``). A topic
  that one of the session's own nodes already publishes is written through that node.

On ROS 1 all of a session's DSL nodes share the process's one ROS node; if one of these
is the first node created, that ROS node is named after the first node the user creates
later (see :meth:`ipyros.ros1.runtime.ProcessNode.start`).
"""

from __future__ import annotations

import queue
import statistics
import time
from dataclasses import dataclass
from typing import Any, Mapping, Optional

from ..core import msgtypes
from ..core.errors import MessageTypeError
from ..core.model import GuardModel
from ..core.names import tool_name
from ..core.slots import arrival
from ..dsl import engine_of, node_of, rosNode
from ..node.session import current


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
    """What arrived on one topic while listening, as ``rostopic hz``, ``bw`` and ``delay`` measure it.

    A latched message that a new subscriber is sent again (``replayed``) was not published
    while listening, so it counts for nothing but itself: two latched publishers answering
    together are not a 2 kHz topic. The rate is each publisher's, measured between its
    first and last message, summed over the publishers.
    """

    count: int  # messages published while listening (replays not counted)
    replayed: int = 0
    hz: Optional[float] = None  # None until one publisher has sent two messages
    min_s: float = 0.0  # the shortest, the longest interval between two messages of a publisher, and their spread
    max_s: float = 0.0
    std_s: float = 0.0
    bytes_per_s: Optional[float] = None
    sizes: tuple[int, int, float] = (0, 0, 0.0)  # min, max, mean bytes of a message
    delays: tuple[float, ...] = ()  # mean, min, max, std dev of now - header.stamp, s; () without stamps

    def describe(self, window: float) -> str:
        """The rate as a person should read it: a number, or why there is none."""
        if self.hz is not None:
            return f"{self.hz:.1f}"
        if self.count:  # one message from each publisher: the interval is longer than we listened
            return f"< {2 / window:.2g}"
        return "latched" if self.replayed else "none"


def _stamp(msg: Any) -> Optional[float]:
    """``msg.header.stamp`` in seconds (rospy's Time or ROS 2's), or None without one (or a zero one)."""
    stamp = getattr(getattr(msg, "header", None), "stamp", None)
    if stamp is None:
        return None
    seconds = stamp.to_sec() if hasattr(stamp, "to_sec") else stamp.sec + stamp.nanosec * 1e-9
    return seconds or None


class _Arrivals:
    """A handler that notes when each message arrives, from whom, how big, how late."""

    def __init__(self) -> None:
        self.by_sender: dict[str, list[tuple[float, int]]] = {}
        self.replayed = 0
        self.delays: list[float] = []

    def __call__(self, msg: Any) -> None:
        now, came = time.monotonic(), arrival()
        if came is not None and came.replayed:
            self.replayed += 1
            return
        self.by_sender.setdefault(came.sender if came else "?", []).append((now, came.size if came else 0))
        stamp = _stamp(msg)
        if stamp is not None:
            self.delays.append(time.time() - stamp)

    def rate(self) -> Rate:
        senders = [list(arrivals) for arrivals in list(self.by_sender.values())]
        count = sum(map(len, senders))
        hz, gaps = 0.0, []
        for arrivals in senders:
            times = [t for t, _ in arrivals]
            if len(times) > 1 and times[-1] > times[0]:
                hz += (len(times) - 1) / (times[-1] - times[0])
                gaps += [b - a for a, b in zip(times, times[1:])]
        every = sorted(a for arrivals in senders for a in arrivals)
        sizes = [size for _, size in every]
        span = every[-1][0] - every[0][0] if len(every) > 1 else 0.0
        delays = list(self.delays)
        return Rate(count, self.replayed, hz if gaps else None,
                    min(gaps, default=0.0), max(gaps, default=0.0), statistics.pstdev(gaps) if gaps else 0.0,
                    sum(sizes[1:]) / span if span > 0 else None,
                    (min(sizes), max(sizes), sum(sizes) / len(sizes)) if sizes else (0, 0, 0.0),
                    (statistics.fmean(delays), min(delays), max(delays), statistics.pstdev(delays)) if delays else ())


class RateMeter:
    """Listen to ``topics`` ({name: type}) while in a ``with`` block; :meth:`rates` says what arrived so far.

    A topic whose message class is not installed here cannot be listened to: its rate is
    None. The listening node is shut down when the block ends, Ctrl-C or not.
    """

    def __init__(self, topics: Mapping[str, str]) -> None:
        self.topics = dict(topics)
        self.node = rosNode(tool_name("hz"))
        self._arrivals: dict[str, _Arrivals] = {}
        for topic, type_name in self.topics.items():
            try:
                msgtypes.resolve_message(type_name)
            except MessageTypeError:
                continue
            self._arrivals[topic] = _Arrivals()
            self.node.new.subscribe(topic, handler=self._arrivals[topic], msgType=type_name)

    @property
    def listening(self) -> bool:
        """Whether any of the topics could be listened to (their message classes are installed)."""
        return bool(self._arrivals)

    def rates(self) -> dict[str, Optional[Rate]]:
        return {t: self._arrivals[t].rate() if t in self._arrivals else None for t in self.topics}

    def __enter__(self) -> "RateMeter":
        if self.listening:
            self.node.create()
        return self

    def __exit__(self, *exc: Any) -> None:
        self.node.shutdown()


def measure_rates(topics: Mapping[str, str], window: float) -> dict[str, Optional[Rate]]:
    """Listen to ``topics`` ({name: type}) for ``window`` seconds; what arrived on each (see :class:`Rate`).

    Ctrl-C stops the measurement (KeyboardInterrupt propagates); the node is shut down either way.
    """
    with RateMeter(topics) as meter:
        if meter.listening:
            time.sleep(window)  # the measurement itself: note what arrives in the window
        return meter.rates()


class PromptPublisher:
    """Publishes single messages from the prompt (see the module docstring for how)."""

    #: Seconds to wait for the topic's known subscribers to be connected before a message goes out.
    WAIT = 3.0

    def __init__(self) -> None:
        self._node: Optional[rosNode] = None

    def publish(self, topic: str, type_name: str, msg: Any, latch: bool = False,
                wait: bool = True) -> tuple[str, int]:
        """Send ``msg`` on ``topic`` (a global name); the DSL node that sent it, and to how many subscribers.

        As ``rostopic pub -1`` and ``ros2 topic pub --once`` do, the message waits (at most
        :attr:`WAIT` s) for the subscribers the graph knows to be connected, and is then sent
        once: not latched, so that a base restarting much later is not handed an old command.
        ``latch=True`` keeps it for subscribers that come later too; ``wait=False`` sends at once
        (the messages after the first of ``%pub -r``).
        """
        owner = self._owner(topic, type_name)
        if owner is not None:  # a node of the session sends it: through its guard, if the topic is guarded
            engine = engine_of(owner)
            if engine.model().guard(topic) is None or not engine.writing.send(topic, msg):
                owner.write(topic, msg)
            return owner.name, _connections(owner, topic)
        node = self._node
        if node is None or not node.created:
            node = self._node = rosNode(tool_name("pub"))
        declared = node.model().topic(topic, "publish", "new")
        if declared is None or declared.type != type_name or declared.latch != latch:
            node.new.publish(topic, msgType=type_name, latch=latch)
        node.create()
        expected = len(_subscribers(topic)) if wait else 0
        deadline = time.monotonic() + self.WAIT
        while _connections(node, topic) < expected and time.monotonic() < deadline:
            time.sleep(0.02)
        node.write(topic, msg)
        return node.name, _connections(node, topic)

    def guard(self, topic: str, type_name: str) -> Optional[tuple[str, GuardModel]]:
        """The guard what :meth:`publish` sends on ``topic`` passes, with the name of the node it stands on (a
        running node of the session guards the topic), if any."""
        owner = self._owner(topic, type_name)
        guard = None if owner is None else engine_of(owner).model().guard(topic)
        return None if guard is None else (owner.name, guard)

    def _owner(self, topic: str, type_name: str) -> Optional[rosNode]:
        """A running node of the session (not ours) that publishes ``topic`` with that type, or guards it (then
        what ``%pub`` sends passes the guard, as every message on that topic does)."""
        for engine in list(current().nodes.values()):
            if engine.owner is self._node or not engine.created:
                continue
            model = engine.model()
            declared = model.topic(topic, "publish", "new") or (model.guard(topic) and model.topic(topic, "publish"))
            if declared is not None and declared.type == type_name:
                return node_of(engine)
        return None

    def close(self) -> None:
        """Stop advertising everything published so far (and latched, with ``latch=True``)."""
        if self._node is not None:
            self._node.shutdown()
            self._node = None


def _connections(node: rosNode, topic: str) -> int:
    """How many subscribers ``node``'s publication of ``topic`` is connected to now."""
    return sum(sent.connections for sent in engine_of(node).sent() if sent.topic == topic)


def _subscribers(topic: str) -> tuple[str, ...]:
    """The nodes the graph says subscribe to ``topic`` now (read once, from the master or discovery)."""
    try:
        snap = current().backend.graph_snapshot(timeout=2.0)
    except Exception:  # noqa: BLE001 - no graph to read: send without waiting, as before
        return ()
    return snap.subscribers.get(topic, ())
