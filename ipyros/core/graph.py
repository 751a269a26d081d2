"""The ROS graph as plain data: which topics (with types), publishers, subscribers, services and nodes there are.

A :class:`GraphSnapshot` is immutable and sorted: readers (completion, ``%topics``, the
DSL's type checks) take one and never wait. Where snapshots come from is each backend's
business (ROS 1: the master, :mod:`ipyros.ros1.graph`; ROS 2: discovery,
:mod:`ipyros.ros2.graph`); :class:`ipyros.tools.graph.GraphCache` keeps one fresh.
"""

from __future__ import annotations

import bisect
import fnmatch
import time
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Callable, Iterable, Mapping, Optional, Sequence, TypeVar

from .errors import BaseNodeError

__all__ = ["EMPTY", "ActionEntry", "GraphSnapshot", "actions_of", "frozen", "name_matches", "names_with_prefix",
           "settled"]


def frozen(mapping: dict) -> Mapping:
    """A read-only view of ``mapping`` with its keys in sorted order."""
    return MappingProxyType({k: mapping[k] for k in sorted(mapping)})


@dataclass(frozen=True)
class GraphSnapshot:
    """The ROS graph as the master (ROS 1) or discovery (ROS 2) described it at ``taken_at`` (``time.time()``).

    All mappings are read-only and sorted by key; node lists are sorted tuples.
    ``topics`` holds every topic somebody publishes or subscribes to, with its type
    (``""`` when the master does not know it yet). With the master down ``master_up`` is
    False, and everything is empty unless :class:`GraphCache` kept the last graph (``stale``).
    """

    topics: Mapping[str, str] = field(default_factory=lambda: MappingProxyType({}))
    publishers: Mapping[str, tuple[str, ...]] = field(default_factory=lambda: MappingProxyType({}))
    subscribers: Mapping[str, tuple[str, ...]] = field(default_factory=lambda: MappingProxyType({}))
    services: Mapping[str, tuple[str, ...]] = field(default_factory=lambda: MappingProxyType({}))
    nodes: tuple[str, ...] = ()
    taken_at: float = 0.0
    master_up: bool = False
    #: The master is down and this is the last graph it described (``known_at``): still good to
    #: complete names from, not to act on.
    stale: bool = False
    known_at: float = 0.0
    #: ``topics``' keys as a sorted tuple: prefix searches bisect it (1,000 topics or 100,000).
    topic_names: tuple[str, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "topic_names", tuple(sorted(self.topics)))

    # -- queries --------------------------------------------------------------
    def topics_with_prefix(self, prefix: str) -> list[str]:
        """Topic names starting with ``prefix``, sorted; O(log n + matches)."""
        return names_with_prefix(self.topic_names, prefix)

    def nodes_with_prefix(self, prefix: str) -> list[str]:
        """Node names starting with ``prefix``, sorted."""
        return names_with_prefix(self.nodes, prefix)

    def topics_matching(self, pattern: str = "", type: Optional[str] = None, node: Optional[str] = None) -> list[str]:
        """Topic names that match all the filters given, sorted.

        ``pattern`` is a glob (``/turtle*/pose``) when it has ``*?[``, else a substring
        (``"cmd"`` finds ``/turtle1/cmd_vel``); empty matches everything. ``type`` is an
        exact type name or a glob (``geometry_msgs/*``). ``node`` keeps the topics that
        node publishes or subscribes to.
        """
        names: Iterable[str] = self.topic_names
        if pattern:
            names = (n for n in names if name_matches(n, pattern))
        if type:
            names = (n for n in names if _matches_exactly(self.topics[n], type))
        if node:
            names = (n for n in names if node in self.publishers.get(n, ()) or node in self.subscribers.get(n, ()))
        return list(names)


def names_with_prefix(sorted_names: Sequence[str], prefix: str) -> list[str]:
    """The names in ``sorted_names`` (sorted!) that start with ``prefix``; a bisection, not a scan."""
    start = bisect.bisect_left(sorted_names, prefix)
    # Every string with the prefix sorts before prefix + the largest code point.
    end = bisect.bisect_left(sorted_names, prefix + "\U0010ffff", start)
    return list(sorted_names[start:end])


def _is_glob(pattern: str) -> bool:
    return any(c in pattern for c in "*?[")


def name_matches(name: str, pattern: str) -> bool:
    """``pattern`` as ``%topics`` reads it: a glob when it has ``*?[``, else a substring; empty matches all."""
    return fnmatch.fnmatchcase(name, pattern) if _is_glob(pattern) else pattern in name


def _matches_exactly(name: str, pattern: str) -> bool:
    """A type matches its name or glob; a ROS 2 type (``pkg/msg/Type``) matches ``pkg/Type`` too."""
    if _is_glob(pattern):
        return fnmatch.fnmatchcase(name, pattern) or fnmatch.fnmatchcase(name.replace("/msg/", "/"), pattern)
    return name == pattern or name.replace("/msg/", "/") == pattern.replace("/msg/", "/")


EMPTY = GraphSnapshot()


@dataclass(frozen=True)
class ActionEntry:
    """An action in the graph: its name, type (``pkg/Type``), the nodes serving it and the nodes calling it."""

    name: str
    type: str
    servers: tuple[str, ...]
    clients: tuple[str, ...]


#: The topics of an action, as ROS 1's actionlib names them (under the action's name).
ROS1_ACTION_TOPICS = ("goal", "cancel", "status", "feedback", "result")


def actions_of(graph: GraphSnapshot) -> list[ActionEntry]:
    """The actions the graph shows, sorted by name.

    An action is not a graph entity of its own on either ROS, but a set of topics (and on
    ROS 2 services) named after it, which cannot be mistaken for each other: ROS 1's
    actionlib uses ``NAME/goal`` (of type ``pkg/TypeActionGoal``) beside ``NAME/cancel``,
    ``/status``, ``/feedback`` and ``/result``; ROS 2 uses ``NAME/_action/feedback`` (of
    type ``pkg/action/Type_FeedbackMessage``) and ``NAME/_action/status``, with the
    services ``send_goal``, ``cancel_goal`` and ``get_result`` beside them. Servers
    subscribe to the goals (ROS 1) or publish the status (ROS 2); clients do the other.
    """
    found = []
    for topic in graph.topic_names:
        type_name = graph.topics[topic]
        if topic.endswith("/_action/feedback") and type_name.endswith("_FeedbackMessage"):
            name = topic[: -len("/_action/feedback")]
            package, kind = type_name.split("/")[0], type_name.split("/")[-1]
            found.append(ActionEntry(name, f"{package}/{kind.removesuffix('_FeedbackMessage')}",
                                     graph.publishers.get(name + "/_action/status", ()),
                                     graph.subscribers.get(topic, ())))
        elif topic.endswith("/goal") and type_name.endswith("ActionGoal"):
            name = topic[: -len("/goal")]
            if all(f"{name}/{part}" in graph.topics for part in ("status", "result")):
                found.append(ActionEntry(name, type_name.removesuffix("ActionGoal"), graph.subscribers.get(topic, ()),
                                         graph.publishers.get(topic, ())))
    return found


T = TypeVar("T")


def settled(read: Callable[[], Optional[T]], node: str, timeout: float = 10.0, settle: float = 0.5,
            alive: Optional[Callable[[], bool]] = None, clock: Callable[[], float] = time.monotonic,
            sleep: Callable[[float], None] = time.sleep) -> Optional[T]:
    """What ``read()`` gives for ``node`` (its interface in the graph; None while it is not there) once it has
    given the same for ``settle`` seconds: a node registers its topics one by one as it starts, and what it has
    registered halfway is not its interface. At ``timeout``, what it gives then (None: the node never showed up:
    the caller says so in its ROS's words). A :class:`BaseNodeError` at once when ``alive()`` (of the process
    that should make the node) turns False: a node that crashed at start is not waited for. Both ROS wait so."""
    deadline = clock() + timeout
    last: Optional[T] = None
    stable_since = clock()
    while True:
        current = read()
        now = clock()
        if current != last:
            last, stable_since = current, now
        elif current is not None and now - stable_since >= settle:
            return current
        if alive is not None and not alive():
            raise BaseNodeError(f"node {node} ended before it settled")
        if now > deadline:
            return current
        sleep(0.05)
