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
    (names starting with ``_``) are left out, as ``ros2 node list`` leaves them out.
    """
    topics = {name: short_name(types[0]) if len(types) == 1 else ""
              for name, types in graph.get_topic_names_and_types()}
    pubs: dict[str, list[str]] = {}
    subs: dict[str, list[str]] = {}
    srvs: dict[str, list[str]] = {}
    nodes = []
    for name, namespace in graph.get_node_names_and_namespaces():
        if name.startswith("_"):
            continue
        fullname = namespace.rstrip("/") + "/" + name
        nodes.append(fullname)
        for found, into in ((graph.get_publisher_names_and_types_by_node, pubs),
                            (graph.get_subscriber_names_and_types_by_node, subs),
                            (graph.get_service_names_and_types_by_node, srvs)):
            try:
                for topic, _ in found(name, namespace):
                    into.setdefault(topic, []).append(fullname)
            except NodeNameNonExistentError:  # it left between the two calls
                continue
    return GraphSnapshot(
        topics=frozen(topics),
        publishers=frozen({t: tuple(sorted(set(n))) for t, n in pubs.items()}),
        subscribers=frozen({t: tuple(sorted(set(n))) for t, n in subs.items()}),
        services=frozen({s: tuple(sorted(set(n))) for s, n in srvs.items()}),
        nodes=tuple(sorted(set(nodes))),
        taken_at=time.time(),
        master_up=True,
    )
