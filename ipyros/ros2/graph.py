"""The ROS 2 graph as a :class:`~ipyros.core.graph.GraphSnapshot`, for ``%topics`` and completion; a running
node's interface, as a wrapping node reads it.

ROS 2 has no master to ask: each process discovers its peers and keeps what it learnt
(DDS discovery, here through the session's hidden graph node). Reading that is local and
takes no round trip, so a snapshot is as fresh as discovery is: on one machine, a node
shows up or goes away within a fraction of a second.
"""

from __future__ import annotations

import time
from typing import Any, Callable, Optional

from rclpy.node import Node, NodeNameNonExistentError

from ..core import msgtypes
from ..core.errors import BaseNodeError
from ..core.graph import GraphSnapshot, frozen, settled
from ..core.msgtypes import short_name
from ..core.records import Interface
from .runtime import domain_id

__all__ = ["node_interface", "snapshot", "wait_for_node"]


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


# -- a node's interface, as discovery sees it --------------------------------------------------

#: What every rclpy node has: not part of the interface a wrapper would reuse.
_PLUMBING_TOPICS = {"/rosout", "/parameter_events"}
_PLUMBING_SERVICES = ("/describe_parameters", "/get_parameter_types", "/get_parameters", "/list_parameters",
                      "/set_parameters", "/set_parameters_atomically", "/get_type_description",
                      "/get_logger_levels", "/set_logger_levels")


def node_interface(graph: Node, fullname: str) -> Any:
    """The publications, subscriptions and services of the running node ``fullname``, or None if unseen."""
    namespace, name = fullname.rsplit("/", 1)
    namespace = namespace or "/"
    if (name, namespace) not in graph.get_node_names_and_namespaces():
        return None
    left_out: list[str] = []

    def entries(found: list[tuple[str, list[str]]], plumbing: Callable[[str], bool], what: str) -> list:
        kept = []
        for topic, types in sorted(found):
            if plumbing(topic):
                left_out.append(f"{topic} ({what})")
            else:
                kept.append((topic, msgtypes.short_name(types[0]) if len(types) == 1 else ""))
        return kept

    return Interface(
        node=fullname,
        publications=entries(graph.get_publisher_names_and_types_by_node(name, namespace),
                             lambda t: t in _PLUMBING_TOPICS, "publishes"),
        subscriptions=entries(graph.get_subscriber_names_and_types_by_node(name, namespace),
                              lambda t: t in _PLUMBING_TOPICS, "subscribes"),
        services=entries(graph.get_service_names_and_types_by_node(name, namespace),
                         lambda s: s.startswith(fullname + "/") and s.endswith(_PLUMBING_SERVICES), "serves"),
        left_out=left_out,
    )


def wait_for_node(graph: Node, fullname: str, timeout: float = 10.0, settle: float = 0.5,
                  alive: Optional[Callable[[], bool]] = None) -> Any:
    """Wait until ``fullname`` is in the graph and its interface has been unchanged for ``settle`` s.

    Raises :class:`BaseNodeError` if it never shows up, at once when ``alive()`` turns False.
    """
    current = settled(lambda: node_interface(graph, fullname), fullname, timeout, settle, alive)
    if current is None:
        names = ", ".join(sorted(ns.rstrip("/") + "/" + n for n, ns in graph.get_node_names_and_namespaces()
                                 if not n.startswith("_"))) or "none"
        raise BaseNodeError(f"node {fullname} did not appear in the ROS 2 graph (ROS_DOMAIN_ID {domain_id()}) after "
                            f"{timeout:g}s: start it first (nodes seen: {names})")
    return current
