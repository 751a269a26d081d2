"""The ROS 2 graph as a :class:`~ipyros.core.graph.GraphSnapshot`, for ``%topics`` and completion.

ROS 2 has no master to ask: each process discovers its peers and keeps what it learnt
(DDS discovery, here through the session's hidden graph node). Reading that is local and
takes no round trip, so a snapshot is as fresh as discovery is: on one machine, a node
shows up or goes away within a fraction of a second.
"""

from __future__ import annotations

import time
from typing import Any

from rclpy.node import NodeNameNonExistentError

from ..core.graph import GraphSnapshot, frozen
from ..core.msgtypes import short_name

__all__ = ["snapshot"]


def snapshot(graph: Any) -> GraphSnapshot:
    """What the graph node ``graph`` has discovered: topics with types (``pkg/Type``, the session's one
    spelling on both ROS), who publishes, subscribes and serves what. ipyros's own hidden nodes
    (names starting with ``_``) are left out, as ``ros2 node list`` leaves them out (their topics stay).

    Read node by node, and the thread lets others run between two nodes: each of rclpy's graph
    queries holds the GIL for all its length, so one query for all 10,000 topics of a robot
    (``get_topic_names_and_types``, 30 ms) would stall a TAB pressed meanwhile, while a node's few
    dozen take well under a millisecond (bench/completion.py measures it).
    """
    types: dict[str, set[str]] = {}
    pubs: dict[str, list[str]] = {}
    subs: dict[str, list[str]] = {}
    srvs: dict[str, list[str]] = {}
    nodes = []
    for name, namespace in graph.get_node_names_and_namespaces():
        fullname = namespace.rstrip("/") + "/" + name
        try:
            published = graph.get_publisher_names_and_types_by_node(name, namespace)
            subscribed = graph.get_subscriber_names_and_types_by_node(name, namespace)
            served = graph.get_service_names_and_types_by_node(name, namespace)
        except NodeNameNonExistentError:  # it left between two calls
            continue
        finally:
            time.sleep(0)  # hand the GIL to a waiting thread (the prompt's) before the next node
        for topic, names in (*published, *subscribed):
            types.setdefault(topic, set()).update(names)
        if name.startswith("_"):
            continue
        nodes.append(fullname)
        for found, into in ((published, pubs), (subscribed, subs), (served, srvs)):
            for topic, _ in found:
                into.setdefault(topic, []).append(fullname)
    # a topic whose endpoints disagree on its type has none: nothing passes between them
    topics = {name: short_name(next(iter(found))) if len(found) == 1 else "" for name, found in types.items()}
    return GraphSnapshot(
        topics=frozen(topics),
        publishers=frozen({t: tuple(sorted(set(n))) for t, n in pubs.items()}),
        subscribers=frozen({t: tuple(sorted(set(n))) for t, n in subs.items()}),
        services=frozen({s: tuple(sorted(set(n))) for s, n in srvs.items()}),
        nodes=tuple(sorted(set(nodes))),
        taken_at=time.time(),
        master_up=True,
    )
