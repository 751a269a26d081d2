"""The ROS 1 parameter server: reads and writes by global name, each value checked first (what it can hold:
:func:`ipyros.core.paramvalues.check_ros1`), and a watch of one parameter, set by anyone."""

from __future__ import annotations

import threading
from typing import Any, Callable

import rospy

from ..core.paramvalues import check_ros1 as check_param
from . import rospy_inside

__all__ = ["ParamWatch", "check_param", "delete_param", "get_param", "has_param", "set_param"]


def get_param(name: str, default: Any = KeyError) -> Any:
    if default is KeyError:
        return rospy.get_param(name)
    return rospy.get_param(name, default)


def set_param(name: str, value: Any) -> None:
    check_param(name, value)
    rospy.set_param(name, value)


def has_param(name: str) -> bool:
    return rospy.has_param(name)


def delete_param(name: str) -> None:
    rospy.delete_param(name)


class ParamWatch:
    """Tell ``tell(value)`` each time the parameter ``name`` (a global name) is set, by anyone.

    The master calls a node's ``paramUpdate`` for the parameters it subscribed to
    (``subscribeParam``, which ``rospy.get_param_cached`` makes); rospy keeps them in its
    parameter cache, whose one notifier this module dispatches to the watches by name.
    """

    _lock = threading.Lock()
    _watches: dict[str, list["ParamWatch"]] = {}

    def __init__(self, name: str, tell: Callable[[Any], None]) -> None:
        self.name, self.tell = name.rstrip("/"), tell
        with ParamWatch._lock:
            rospy_inside.notify_param_sets(ParamWatch._notify)
            ParamWatch._watches.setdefault(self.name, []).append(self)
        rospy.get_param_cached(self.name)  # subscribes: from now on the master tells this process

    @staticmethod
    def _notify(key: str, value: Any) -> None:
        with ParamWatch._lock:
            watches = list(ParamWatch._watches.get(key.rstrip("/"), ()))
        for watch in watches:
            watch.tell(value)

    def close(self) -> None:
        with ParamWatch._lock:
            watches = ParamWatch._watches.get(self.name, [])
            if self in watches:
                watches.remove(self)
