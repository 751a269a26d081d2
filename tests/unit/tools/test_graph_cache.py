"""GraphCache's refresh thread on a graph that is slow to read: it rests in proportion, off the prompt's thread."""

from __future__ import annotations

import threading
import time

from ipyros.core.graph import GraphSnapshot
from ipyros.tools.graph import REST, GraphCache


def test_a_slow_refresh_is_followed_by_a_proportional_rest():
    calls: list[float] = []
    callers: set[str] = set()

    def slow_source(timeout: float) -> GraphSnapshot:
        calls.append(time.monotonic())
        callers.add(threading.current_thread().name)
        time.sleep(0.05)  # as ROS 1's 10,000 topics take 0.4 s
        return GraphSnapshot(topics={"/t": "std_msgs/String"}, master_up=True, taken_at=time.time())

    graph = GraphCache(slow_source, lambda: "test", period=0.001).start()
    try:
        assert graph.wait_first(5.0)
        time.sleep(1.0)
    finally:
        graph.stop()
    assert graph.snapshot.topics == {"/t": "std_msgs/String"}
    assert graph.refresh_seconds >= 0.05
    # each refresh (>= 0.05 s) is followed by a rest of REST times as long: at most 1 + 1.0 / 0.3 of them
    gaps = [later - earlier for earlier, later in zip(calls, calls[1:])]
    assert gaps and min(gaps) >= (1 + REST) * 0.05 * 0.95, gaps
    assert callers == {"ipyros-graph"}  # never the caller's thread
