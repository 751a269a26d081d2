"""Test helpers that need no ROS: shared by the ROS 1 suite (tests/) and the ROS 2 suite (tests_ros2/)."""

from __future__ import annotations

import time
from typing import Any, Callable, Iterator


def wait_for(predicate: Callable[[], Any], timeout: float = 10.0, interval: float = 0.02, what: str = "condition"):
    """Poll ``predicate`` until it returns a truthy value; fail the test after ``timeout``."""
    deadline = time.monotonic() + timeout
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout}s waiting for {what}")
        time.sleep(interval)


def node_maker(session: Any) -> Iterator[Callable[..., Any]]:
    """The body of a ``make_node`` fixture: build rosNodes in ``session``, shut down when the test ends."""
    from ipyros import rosNode

    nodes = []

    def make(name: str, **kwargs: Any) -> Any:
        node = rosNode(name, session=session, **kwargs)
        nodes.append(node)
        return node

    yield make
    for node in nodes:
        node.shutdown()
