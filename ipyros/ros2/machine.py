"""The keeper on ROS 2 (see :mod:`ipyros.processes.keeper`): an rclpy node of its own on the robot's machine.

    python -m ipyros.machine --name robot1 [--allow PACKAGE ...] [--token-file FILE]

Its callbacks run on a multi-threaded executor, each subscription in a group of its own: a request that
starts a guard's stop process (seconds) never holds up the heartbeats that keep the other leases.
"""

from __future__ import annotations

import os
import sys
import threading
from pathlib import Path
from typing import Any, Callable, Optional

from ..core import msgtypes
from ..core.qos import Qos
from ..processes.keeper import Keeper, Lookup, Token, child_env, log_line, serve, token_path, unknown_packages
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


def _own_participant(name: str) -> tuple[Any, Any]:
    """An rclpy context of its own (a DDS participant, an executor thread) and its node ``name``."""
    from .runtime import ProcessNode

    process = ProcessNode()
    process.start(name)
    return process, process.host(f"/{name}", parameters=False)


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
        self._beating: Any = None  # the heartbeats' (see beat_node)

    def relay(self, source: str, target: str, type_name: str, gate: Any, complain: Callable[[str], None]) -> Any:
        """The runtime's relay (bytes on, QoS taken from the basenode's publishers), on a node of its own in an
        rclpy context of its own: a camera's traffic never shares a participant with the leases' heartbeats."""
        from .endpoints import Relay

        cls = msgtypes.resolve_message(type_name)[1]  # rclpy needs the type's Python package, even for bytes
        process, node = self._relays_node()
        return Relay(process, node, source, target, cls, lambda got: complain(wrong_type_line(source, type_name, got)),
                     complain, gate=gate)

    def _relays_node(self) -> tuple[Any, Any]:
        if self._relaying is None:
            self._relaying = _own_participant(self._relays_name)
        return self._relaying

    def service_relay(self, source: str, target: str, type_name: str, complain: Callable[[str], None]) -> Any:
        from .endpoints import ServiceRelay

        process, node = self._relays_node()
        return ServiceRelay(process, node, source, target, msgtypes.resolve_service(type_name)[1], complain)

    def action_relay(self, source: str, target: str, type_name: str, complain: Callable[[str], None]) -> Any:
        from .actions import ActionRelay

        process, node = self._relays_node()
        return ActionRelay(process, node, source, target, msgtypes.resolve_action(type_name)[1],
                           lambda got: complain(wrong_type_line(f"a part of {source}", type_name, got)), complain)

    def close(self) -> None:
        for held in (self._relaying, self._beating):
            if held is not None:
                held[0].shutdown("the keeper ends")
        self._relaying = self._beating = None

    def address(self) -> str:
        server = os.environ.get("ROS_DISCOVERY_SERVER", "")
        found = f", discovery server on port {server.rsplit(':', 1)[-1]}" if server.startswith("127.0.0.1:") else ""
        return f"domain {os.environ.get('ROS_DOMAIN_ID') or 0}{found}"

    def publisher(self, topic: str, type_name: str, latch: bool) -> _Outlet:
        from .qosmatch import profile_of

        cls = msgtypes.resolve_message(type_name)[1]
        qos = profile_of(Qos(durability="transient_local") if latch else Qos(depth=10))  # latched: the last one
        return _Outlet(self._node, self._node.create_publisher(cls, topic, qos))

    def subscribe(self, topic: str, type_name: str, callback: Callable[[Any], None],
                  lossy: bool = False) -> _Subscription:
        from rclpy.callback_groups import MutuallyExclusiveCallbackGroup

        from .qosmatch import profile_of

        cls = msgtypes.resolve_message(type_name)[1]
        qos = profile_of(Qos(depth=10, reliability="best_effort" if lossy else "reliable"))
        if lossy:
            beats = self.beat_node()
            return _Subscription(beats, beats.create_subscription(cls, topic, callback, qos))
        return _Subscription(self._node, self._node.create_subscription(
            cls, topic, callback, qos, callback_group=MutuallyExclusiveCallbackGroup()))

    def beat_node(self) -> Any:
        """The node the heartbeats are heard on: in a participant of its own (its own rclpy context and executor),
        so that no reliable stream's repairs on a lossy link hold a heartbeat up on its way in (measured: heard on
        the keeper's participant, a beat came more than a lease late now and then once a link had lost 10 % for half
        a minute; heard there too besides this one, within seconds). Made as the keeper starts (see :func:`main`):
        made as the first guard was placed, it was once in a dozen tries not matched with the session for many
        seconds."""
        if self._beating is None:
            self._beating = _own_participant(f"{self._node.get_name()}_beats")
        return self._beating[1]

    def text(self, data: str) -> Any:
        from std_msgs.msg import String

        return String(data=data)

    def deserialize(self, cls: type, data: bytes) -> Any:
        from rclpy.serialization import deserialize_message

        return deserialize_message(data, cls)


def start_discovery_server(port: int, folder: Path, timeout: float = 30.0) -> Any:
    """Start a Fast DDS discovery server on ``port`` (:mod:`ipyros.ros2.discoveryserver`: a child that ends with the
    keeper) and make this process, and what it starts, its clients; the process, or a one-line
    :class:`~ipyros.core.errors.IpyrosError`. Called before rclpy starts here."""
    from ..core.errors import IpyrosError
    from ..processes.process import spawn
    from .discoveryserver import write_profile

    env = {k: v for k, v in child_env().items() if k not in ("ROS_DISCOVERY_SERVER", "ROS_SUPER_CLIENT")}
    env["FASTDDS_DEFAULT_PROFILES_FILE"] = str(write_profile(port, folder))
    log = folder / f"ipyros-discovery-server-{port}.log"
    fd = os.open(log, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    try:
        proc = spawn([sys.executable, "-m", "ipyros.ros2.discoveryserver", str(port)], env=env, log=fd,
                     stdout_pipe=True)
    finally:
        os.close(fd)
    said: list[bytes] = []
    reader = threading.Thread(target=lambda: said.append(proc.stdout.readline()), daemon=True)
    reader.start()
    reader.join(timeout)
    if not said or not said[0].startswith(b"ready"):
        proc.kill()
        raise IpyrosError(f"the discovery server on port {port} did not start (see {log}): is the port in use? "
                          "give another with --discovery-server PORT")
    os.environ["ROS_DISCOVERY_SERVER"] = f"127.0.0.1:{port}"
    os.environ["ROS_SUPER_CLIENT"] = "TRUE"  # the keeper looks at the graph (a relay's source's QoS)
    return proc


def main(name: str, token_file: Any, allowed: frozenset[str] = frozenset(),
         discovery_port: Optional[int] = None) -> int:
    import rclpy
    from rclpy.executors import MultiThreadedExecutor
    from rclpy.node import Node

    from ..core.errors import IpyrosError

    if discovery_port is not None:
        try:
            start_discovery_server(discovery_port, token_path(name).parent)
        except IpyrosError as error:
            print(f"ipyros machine: {error}", file=sys.stderr)
            return 2
    rclpy.init(signal_handler_options=rclpy.signals.SignalHandlerOptions.NO)
    node = Node(f"ipyros_machine_{name}", start_parameter_services=False)
    ros = RclpyKeeper(node)
    ros.beat_node()  # discovered while the keeper starts, not as the first session places a guard
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
