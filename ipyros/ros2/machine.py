"""The keeper on ROS 2 (see :mod:`ipyros.processes.keeper`): an rclpy node of its own on the robot's machine.

    python -m ipyros.machine --name robot1 [--allow PACKAGE ...] [--token-file FILE]

Its callbacks run on a multi-threaded executor, each subscription in a group of its own: a request that
starts a guard's stop process (seconds) never holds up the heartbeats that keep the other leases.
"""

from __future__ import annotations

import os
import sys
import threading
from typing import Any, Callable

from ..core import msgtypes
from ..core.qos import Qos
from ..processes.keeper import Keeper, Lookup, Token, log_line, serve, token_path, unknown_packages
from ..processes.relayhost import wrong_type_line
from . import nodes

__all__ = ["RclpyKeeper", "main"]


class _Outlet:
    def __init__(self, node: Any, publisher: Any) -> None:
        self._node, self._pub = node, publisher

    def write(self, msg: Any) -> None:
        self._pub.publish(msg)

    def count(self) -> int:
        return self._pub.get_subscription_count()

    def close(self) -> None:
        self._node.destroy_publisher(self._pub)


class _Subscription:
    def __init__(self, node: Any, subscription: Any) -> None:
        self._node, self._sub = node, subscription

    def close(self) -> None:
        self._node.destroy_subscription(self._sub)


class RclpyKeeper(Lookup):
    """What the keeper asks of ROS 2, with rclpy, on ``node``."""

    nodes = nodes  # basenodes found as ros2 run (the ament index) finds them
    sentinel = "ipyros.ros2.sentinel"

    name = "ROS 2"

    relay_host = "ipyros.ros2.relayhost"

    def __init__(self, node: Any, relays_name: str = "") -> None:
        self._node = node
        self._relays_name = relays_name or f"{node.get_name()}_relays"
        self._relaying: Any = None  # the relays' own rclpy context and node (see relay)
        self._beating: Any = None  # the heartbeats' (see _beat_node)

    def relay(self, source: str, target: str, type_name: str, gate: Any, complain: Callable[[str], None]) -> Any:
        """The runtime's relay (bytes on, QoS taken from the basenode's publishers), on a node of its own in an
        rclpy context of its own: a camera's traffic never shares a participant with the leases' heartbeats."""
        from .runtime import ProcessNode, Relay

        cls = msgtypes.resolve_message(type_name)[1]  # rclpy needs the type's Python package, even for bytes
        if self._relaying is None:
            process = ProcessNode()
            process.start(self._relays_name)
            self._relaying = process, process.host(f"/{self._relays_name}", parameters=False)
        process, node = self._relaying
        return Relay(process, node, source, target, cls, lambda got: complain(wrong_type_line(source, type_name, got)),
                     complain, gate=gate)

    def close(self) -> None:
        for held in (self._relaying, self._beating):
            if held is not None:
                held[0].shutdown("the keeper ends")
        self._relaying = self._beating = None

    def address(self) -> str:
        return f"domain {os.environ.get('ROS_DOMAIN_ID') or 0}"

    def publisher(self, topic: str, type_name: str, latch: bool) -> _Outlet:
        from .runtime import profile_of

        cls = msgtypes.resolve_message(type_name)[1]
        qos = profile_of(Qos(durability="transient_local") if latch else Qos(depth=10))  # latched: the last one
        return _Outlet(self._node, self._node.create_publisher(cls, topic, qos))

    def subscribe(self, topic: str, type_name: str, callback: Callable[[Any], None],
                  lossy: bool = False) -> _Subscription:
        from rclpy.callback_groups import MutuallyExclusiveCallbackGroup

        from .runtime import profile_of

        cls = msgtypes.resolve_message(type_name)[1]
        node = self._beat_node() if lossy else self._node
        return _Subscription(node, node.create_subscription(
            cls, topic, callback, profile_of(Qos(depth=10, reliability="best_effort" if lossy else "reliable")),
            callback_group=MutuallyExclusiveCallbackGroup()))

    def _beat_node(self) -> Any:
        """The node the heartbeats are heard on: in a participant of its own (its own rclpy context and executor),
        so that no reliable stream's repairs on a lossy link hold a heartbeat up on its way in."""
        if self._beating is None:
            from .runtime import ProcessNode

            process = ProcessNode()
            name = f"{self._node.get_name()}_beats"
            process.start(name)
            self._beating = process, process.host(f"/{name}", parameters=False)
        return self._beating[1]

    def text(self, data: str) -> Any:
        from std_msgs.msg import String

        return String(data=data)

    def deserialize(self, cls: type, data: bytes) -> Any:
        from rclpy.serialization import deserialize_message

        return deserialize_message(data, cls)


def main(name: str, token_file: Any, allowed: frozenset[str] = frozenset()) -> int:
    import rclpy
    from rclpy.executors import MultiThreadedExecutor
    from rclpy.node import Node

    rclpy.init(signal_handler_options=rclpy.signals.SignalHandlerOptions.NO)
    node = Node(f"ipyros_machine_{name}", start_parameter_services=False)
    ros = RclpyKeeper(node)
    unknown = unknown_packages(ros, allowed, "this machine's ament index")
    if unknown:
        print(unknown, file=sys.stderr)
        node.destroy_node()
        rclpy.try_shutdown()
        return 2
    token = Token.made_or_read(token_file or token_path(name))
    executor = MultiThreadedExecutor(num_threads=4)
    executor.add_node(node)
    threading.Thread(target=executor.spin, name="ipyros-machine-spin", daemon=True).start()
    try:
        serve(Keeper(name, token, ros, log_line, allowed=allowed))
    finally:
        ros.close()
        executor.shutdown(timeout_sec=2.0)
        node.destroy_node()
        rclpy.try_shutdown()
    return 0
