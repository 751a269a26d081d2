"""A guard's process on ROS 2 (see :mod:`ipyros.processes.sentinel`): an rclpy node of its own that publishes the
stop message on the guarded topic when the session's messages stop, and hears the guard's e-stop topic.

    python -m ipyros.ros2.sentinel PIPE_FD SHARED_FD     (started by the session, never by hand)
"""

from __future__ import annotations

import sys
import threading
from typing import Any, Callable

from ..processes.sentinel import Shared, serve

_spun: list[Any] = []


def start(settings: dict[str, Any], shared: Shared,
          wake: threading.Event) -> tuple[Callable[[], None], Callable[[], int]]:
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from rclpy.serialization import deserialize_message
    from std_msgs.msg import Bool

    from ..core import msgtypes
    from ..core.qos import from_model
    from .qosmatch import profile_of

    rclpy.init(signal_handler_options=rclpy.signals.SignalHandlerOptions.NO)
    namespace, _, name = ("/" + settings["node"]).rpartition("/")
    node = Node(name, namespace=namespace or "/", start_parameter_services=False)
    _, cls = msgtypes.resolve_message(settings["type"])
    qos = from_model(settings.get("qos"))
    if settings.get("latch"):
        from dataclasses import replace

        qos = replace(qos, durability="transient_local")
    publisher = node.create_publisher(cls, settings["topic"], profile_of(qos))

    def estop(msg: Any) -> None:
        shared.estop_topic = msg.data
        wake.set()

    if settings.get("estop_topic"):
        node.create_subscription(Bool, settings["estop_topic"], estop, 10)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    spinner = threading.Thread(target=executor.spin, name="ipyros-sentinel-spin", daemon=True)
    spinner.start()
    _spun.extend((executor, node, spinner))

    def publish_stop() -> None:
        publisher.publish(deserialize_message(bytes.fromhex(settings["stop"]), cls))

    return publish_stop, publisher.get_subscription_count


def stop_ros() -> None:
    import rclpy

    if _spun:
        executor, node, spinner = _spun
        executor.shutdown(timeout_sec=1.0)
        node.destroy_node()
        rclpy.try_shutdown()
        spinner.join(2.0)


def main(argv: list[str]) -> int:
    return serve(int(argv[1]), int(argv[2]), start, stop_ros)


if __name__ == "__main__":
    sys.exit(main(sys.argv))
