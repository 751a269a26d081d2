"""Watching parameters change, as ``%params --watch`` shows them (rosparam and ros2 param have no such verb).

Both ROS are read the same way, by looking again: ROS 1's parameter server tells only the
nodes that subscribed to a key, and a ROS 2 node's parameter events say nothing of the
nodes that were there before the watch. A look every half second costs one master call
(ROS 1) or one call per node (ROS 2) and shows every change that lasts longer than that.
"""

from __future__ import annotations

import time
from typing import Any, Callable, Mapping, Optional

__all__ = ["ABSENT", "changes", "watch"]

#: The value of a parameter that is not there (before it appeared, after it went).
ABSENT: Any = type("Absent", (), {"__repr__": lambda self: "(none)"})()


def changes(before: Mapping[str, Any], after: Mapping[str, Any]) -> list[tuple[str, Any, Any]]:
    """``(name, old, new)`` for each parameter that appeared, changed or went (:data:`ABSENT` where it is not)."""
    return [(name, before.get(name, ABSENT), after.get(name, ABSENT)) for name in sorted({*before, *after})
            if before.get(name, ABSENT) != after.get(name, ABSENT)]


def watch(read: Callable[[], Mapping[str, Any]], tell: Callable[[str, Any, Any], None], *, period: float = 0.5,
          count: Optional[int] = None) -> int:
    """Read the parameters every ``period`` s and ``tell(name, old, new)`` each change, until ``count`` changes were
    told (or Ctrl-C: KeyboardInterrupt propagates). Returns how many were told."""
    told, before = 0, dict(read())
    while count is None or told < count:
        time.sleep(period)  # the look's period: what it shows is what changed in between
        after = dict(read())
        for name, old, new in changes(before, after):
            tell(name, old, new)
            told += 1
        before = after
    return told
