"""What ipyros reports, as plain records: a node's status, history and handler versions, a node's interface.

Records are data and nothing else: the DSL and the tools return them, tests read their
fields, files save them. How they look (a table in a terminal, an HTML table in Jupyter)
is the IPython face's business (:mod:`ipyros.ipython.display`), which registers itself
for these types when the extension loads.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any, Iterator, Optional

__all__ = ["History", "Interface", "NodeStatus", "Rows", "StatusRow", "Versions"]


class Rows:
    """A sequence of records (``rows``): ``len``, iteration and indexing go to the rows."""

    rows: tuple[Any, ...]

    def __len__(self) -> int:
        return len(self.rows)

    def __iter__(self) -> Iterator[Any]:
        return iter(self.rows)

    def __getitem__(self, index: int) -> Any:
        return self.rows[index]


@dataclass(frozen=True)
class StatusRow:
    """One line of a node's status: a handler (subscription, timer, service) or a topic it sends on.

    For a handler ``calls`` counts its calls; for a publication or relay (no handler, no
    timing) the messages sent, to ``connections`` subscribers, of which slow ones have
    ``waiting`` messages queued and lost ``dropped`` so far.
    """

    kind: str
    name: str
    handler: str
    calls: int
    rate_hz: float = 0.0
    mean_ms: float = 0.0
    max_ms: float = 0.0
    errors: int = 0
    connections: int = 0
    waiting: int = 0
    dropped: int = 0


@dataclass(frozen=True)
class NodeStatus(Rows):
    """Per handler and per topic sent on: calls, rate, handler time, exceptions, drops."""

    node: str
    running: bool
    rows: tuple[StatusRow, ...]
    params: tuple[tuple[str, str], ...] = ()  # the node's own parameters as they are now (set from outside too)

    def row(self, name: str) -> StatusRow:
        return next(r for r in self.rows if r.name == name)


@dataclass(frozen=True)
class History(Rows):
    """A node's changes, oldest first (:class:`ipyros.core.journal.Change`)."""

    node: str
    rows: tuple[Any, ...]
    path: Any = None  # the file the session writes its history to, if any


@dataclass(frozen=True)
class Versions(Rows):
    """The versions of one handler (:class:`ipyros.core.versions.HandlerVersion`), oldest first."""

    label: str  # e.g. "kobuki /cmd_vel"
    rows: tuple[Any, ...]
    current: Optional[int]  # the number of the version serving now, or None


@dataclass
class Interface:
    """The publish/subscribe/service interface of one running node, as plain data.

    Each entry is ``(global name, type)``; a type is ``""`` when it is not known: a
    topic subscribed to as "any type" (rospy.AnyMsg, topic_tools' ShapeShifter: the
    master records no type for those) that nobody publishes yet, or a service that did
    not answer the probe. ``left_out`` names the ROS plumbing that was seen but is not
    part of the interface (e.g. ``"/rosout (publishes)"``); ``not_seen`` the names
    declared for it that it did not use while it was watched (some nodes advertise only
    after their first input); ``not_installed`` the ``name (type)`` of those whose types this
    Python cannot import, which ``discover()`` left undeclared.
    """

    node: str
    publications: list[tuple[str, str]] = field(default_factory=list)
    subscriptions: list[tuple[str, str]] = field(default_factory=list)
    services: list[tuple[str, str]] = field(default_factory=list)
    left_out: list[str] = field(default_factory=list)
    not_seen: list[str] = field(default_factory=list)
    actions: list[tuple[str, str]] = field(default_factory=list)  # the action servers, found by fold_actions()
    not_installed: list[str] = field(default_factory=list)

    def fold_actions(self) -> "Interface":
        """This interface with the actions the node serves taken out of its topics and services, into
        ``actions`` (``pkg/Type``); the interface itself is left as it was.

        An action is a set of topics (ROS 1: ``NAME/goal`` of a ``pkg/TypeActionGoal`` and
        four more; ROS 2: ``NAME/_action/feedback`` of a ``pkg/Type_FeedbackMessage``, the
        status topic and three services): a wrapper relays it as one unit, so it is one entry.
        """
        found = {}
        for name, type_name in self.publications:  # ROS 2: the server publishes the feedback
            if name.endswith("/_action/feedback") and type_name.endswith("_FeedbackMessage"):
                package, stem = type_name.split("/")[0], type_name.split("/")[-1]
                found[name.removesuffix("/_action/feedback")] = f"{package}/{stem.removesuffix('_FeedbackMessage')}"
        for name, type_name in self.subscriptions:  # ROS 1: the server subscribes to the goals
            if name.endswith("/goal") and type_name.endswith("ActionGoal"):
                found[name.removesuffix("/goal")] = type_name.removesuffix("ActionGoal")

        def part(entry: tuple[str, str]) -> bool:
            head, _, tail = entry[0].rpartition("/")
            return head.removesuffix("/_action") in found and (head.endswith("/_action") or tail in _ROS1_PARTS)

        return replace(self, publications=[e for e in self.publications if not part(e)],
                       subscriptions=[e for e in self.subscriptions if not part(e)],
                       services=[e for e in self.services if not part(e)], actions=sorted(found.items()))


#: The topics of a ROS 1 action under its name (actionlib's).
_ROS1_PARTS = ("goal", "cancel", "status", "feedback", "result")
