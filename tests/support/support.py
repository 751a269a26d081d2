"""Test helpers that need no ROS: shared by every layer of the suite."""

from __future__ import annotations

import os
import time
from pathlib import Path
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


def settled(count: Callable[[], int], quiet: float = 0.3, timeout: float = 10.0, what: str = "the count") -> int:
    """``count()`` once it has stood still for ``quiet`` seconds: what was on its way has arrived (a message sent
    before a pause, say). Fails after ``timeout`` if it never stands still."""
    deadline = time.monotonic() + timeout
    last, since = count(), time.monotonic()
    while time.monotonic() - since < quiet:
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout}s waiting for {what} to stand still (at {last})")
        time.sleep(0.02)
        now = count()
        if now != last:
            last, since = now, time.monotonic()
    return last


def graph_knows(topic: str, side: str = "subscribers", timeout: float = 20.0) -> tuple[str, ...]:
    """Wait until the session's graph lists a node on ``side`` (``"subscribers"``, ``"publishers"``) of ``topic``.

    A peer that just said "ready" is not yet in the graph (ROS 2 discovery may take its 3 s
    announcement period to hear of it): a test wait here, as a user would look at %topics.
    """
    from ipyros.node.session import current

    backend = current().backend
    return wait_for(lambda: getattr(backend.graph_snapshot(timeout=2.0), side).get(topic), timeout,
                    what=f"the graph to list {side} of {topic}")


def graph_forgets(topic: str, side: str = "subscribers", timeout: float = 20.0) -> None:
    """Wait until the session's graph lists no node on ``side`` of ``topic`` (ROS 2 discovery tells of a
    removal a moment later; the ROS 1 master at once)."""
    from ipyros.node.session import current

    backend = current().backend
    wait_for(lambda: not getattr(backend.graph_snapshot(timeout=2.0), side).get(topic), timeout,
             what=f"the graph to drop the {side} of {topic}")


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


#: Processes that live for the whole run (a rosmaster): not leftovers of any one test.
SESSION_PIDS: set[int] = set()


def children() -> set[int]:
    """PIDs of this process's living children (zombies and :data:`SESSION_PIDS` excluded)."""
    out = set()
    kids: list[str] = []
    for task in Path(f"/proc/{os.getpid()}/task").iterdir():  # children of every thread
        try:
            kids += (task / "children").read_text().split()
        except OSError:
            pass
    for pid in map(int, kids):
        if pid in SESSION_PIDS:
            continue
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if state != "Z":
            out.add(pid)
    return out


def request_of(service: type) -> type:
    """A service's request class on either ROS (``SetBool.Request``; ROS 1: ``SetBoolRequest``)."""
    return getattr(service, "Request", None) or service._request_class  # type: ignore[attr-defined]


def response_of(service: type) -> type:
    """A service's response class on either ROS."""
    return getattr(service, "Response", None) or service._response_class  # type: ignore[attr-defined]
