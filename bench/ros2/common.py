"""What the ROS 2 bench's node processes share: rclpy started, a QoS, lines to and from the bench.

A node answers commands on its standard input, one line each, and ends at ``quit`` or
when its input closes (the bench went away).
"""

from __future__ import annotations

import sys
import threading
from typing import Any, Callable, Optional

from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

#: Every endpoint of the bench: what ipyros declares by default (reliable, volatile, 1000 deep).
QOS = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)

#: A camera's best-effort stream (as sensor drivers publish), for the publisher and the subscriber.
BEST_EFFORT = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT, durability=DurabilityPolicy.VOLATILE)


def qos(name: str) -> QoSProfile:
    """The QoS named on a node's command line: ``reliable`` (default) or ``best_effort``."""
    return BEST_EFFORT if name == "best_effort" else QOS


def say(*words: object) -> None:
    sys.stdout.write(" ".join(str(w) for w in words) + "\n")
    sys.stdout.flush()


def stop(node: Any, executor: Any) -> None:
    """End a node spun by :func:`spin_in_background`: the executor first (destroying a node it is
    spinning aborts the process), then the node, then rclpy."""
    import rclpy

    executor.shutdown()
    node.destroy_node()
    rclpy.try_shutdown()


def spin_in_background(node: Any, executor: Optional[Any] = None) -> Any:
    from rclpy.executors import SingleThreadedExecutor

    executor = executor or SingleThreadedExecutor()
    executor.add_node(node)
    threading.Thread(target=executor.spin, daemon=True).start()
    return executor


def serve(commands: Optional[dict[str, Callable[[list[str]], object]]] = None) -> None:
    for line in sys.stdin:
        words = line.split()
        if not words:
            continue
        if words[0] == "quit":
            break
        action = (commands or {}).get(words[0])
        if action is None:
            say("error", f"unknown command {words[0]!r}")
            continue
        answer = action(words[1:])
        if answer is not None:
            say(answer)
