"""A ROS 2 node's parameters: what one can hold (:func:`ipyros.core.paramvalues.check_ros2`), and a watch of one,
set by anyone."""

from __future__ import annotations

from typing import Any, Callable

from rclpy.node import Node

from ..core.paramvalues import check_ros2 as check_param

__all__ = ["ParamWatch", "check_param"]


class ParamWatch:
    """Tell ``tell(value)`` each time the parameter ``key`` of ``node`` (a node of this process) is set, by
    anyone: a ``ros2 param set``, another node's SetParameters call, or this session (rclpy's post-set callback)."""

    def __init__(self, node: Node, key: str, tell: Callable[[Any], None]) -> None:
        self._node, self.key, self.tell = node, key, tell
        node.add_post_set_parameters_callback(self._set)

    def _set(self, parameters: list[Any]) -> None:
        for parameter in parameters:
            if parameter.name == self.key:
                self.tell(parameter.value)

    def close(self) -> None:
        self._node.remove_post_set_parameters_callback(self._set)
