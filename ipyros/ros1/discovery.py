"""Black-box discovery: what a running node publishes, subscribes and serves (paper section IV-A).

The paper wraps a node whose source you may not have by first asking ROS about it
(``rosnode info``, ``rostopic info``). :func:`discover` does that in one call, from the
master alone: ``getSystemState`` says which topics and services the node registered,
``getTopicTypes`` gives the topics' types, and a service's type comes from probing the
service itself (services do not tell the master their type), as ``rosservice`` does.

What every node has, ROS's own plumbing, is not part of the interface and is listed
in :attr:`~ipyros.core.records.Interface.left_out` instead: the ``/rosout`` log publication, ``/clock``
(subscribed under simulated time) and the ``~get_loggers``/``~set_logger_level``
services that rospy and roscpp give every node.

A node registers its topics one by one while it starts, so reading it once right after
launch can miss some: :func:`wait_for_node` waits until the node is there and its
interface has stopped changing.
"""

from __future__ import annotations

import time
from typing import Callable, Optional

from ..core.errors import BaseNodeError, IpyrosError, MasterError
from ..core.graph import GraphSnapshot, settled
from ..core.records import Interface
from . import introspect
from .graph import fetch_snapshot

__all__ = ["discover", "global_node_name", "wait_for_node"]

CALLER_ID = "/ipyros_discovery"

#: Topics every node has whatever it does: (name, direction) pairs left out of interfaces.
PLUMBING_TOPICS = {("/rosout", "publishes"), ("/rosout_agg", "subscribes"), ("/clock", "subscribes")}
#: Services every rospy and roscpp node offers, below its own name.
PLUMBING_SERVICES = ("get_loggers", "set_logger_level")


def global_node_name(node_name: str) -> str:
    """``relay`` → ``/relay``: node names given without namespace live in the root namespace."""
    if not node_name or not node_name.strip("/"):
        raise BaseNodeError(f"node name {node_name!r} is empty; give the node's name, e.g. '/move_base'")
    return node_name if node_name.startswith("/") else "/" + node_name


def discover(master_uri: str, node_name: str, timeout: float = 5.0) -> Interface:
    """The interface of the running node ``node_name``, read once from the master at ``master_uri``.

    Waits up to ``timeout`` seconds for the node to be registered (it may just be
    starting); raises :class:`BaseNodeError` if it never is, :class:`MasterError` if
    the master does not answer.
    """
    node = global_node_name(node_name)
    deadline = time.monotonic() + timeout
    while True:
        snapshot = _snapshot(master_uri)
        if node in snapshot.nodes:
            return _with_service_types(master_uri, _read(snapshot, node))
        if time.monotonic() > deadline:
            raise _not_registered(master_uri, node, snapshot, timeout)
        time.sleep(0.05)


def wait_for_node(master_uri: str, node_name: str, timeout: float = 10.0, settle: float = 0.5,
                  alive: Optional[Callable[[], bool]] = None) -> Interface:
    """Wait until ``node_name`` is registered and its interface has been unchanged for ``settle`` seconds.

    Returns the interface then (with service types). A node still registering things
    when ``timeout`` runs out is returned as it is at that moment; one that never
    registered raises :class:`BaseNodeError`, at once when ``alive()`` (of the process
    that should register it) turns False: a node that crashed at start is not waited for.
    """
    node = global_node_name(node_name)
    seen: list[GraphSnapshot] = []  # the last snapshot read: what a node that never showed up is told of

    def read() -> Optional[Interface]:
        seen[:] = [_snapshot(master_uri)]
        return _read(seen[0], node) if node in seen[0].nodes else None

    last = settled(read, node, timeout, settle, alive)
    if last is None:
        raise _not_registered(master_uri, node, seen[0], timeout)
    return _with_service_types(master_uri, last)


def _snapshot(master_uri: str) -> GraphSnapshot:
    snapshot = fetch_snapshot(master_uri, timeout=2.0)
    if not snapshot.master_up:
        raise MasterError(f"no ROS master answers at {master_uri}; start one (roscore) or check ROS_MASTER_URI")
    return snapshot


def _not_registered(master_uri: str, node: str, snapshot: GraphSnapshot, timeout: float) -> BaseNodeError:
    nodes = ", ".join(n for n in snapshot.nodes if n != CALLER_ID) or "none"
    return BaseNodeError(
        f"node {node} is not registered with the master at {master_uri} after {timeout:g}s: "
        f"start it first (registered nodes: {nodes})"
    )


def _read(snapshot: GraphSnapshot, node: str) -> Interface:
    """The node's topics and service names from one snapshot (services still untyped)."""
    interface = Interface(node)
    for direction, registry, into in (
        ("publishes", snapshot.publishers, interface.publications),
        ("subscribes", snapshot.subscribers, interface.subscriptions),
    ):
        for topic, nodes in registry.items():
            if node not in nodes:
                continue
            if (topic, direction) in PLUMBING_TOPICS:
                interface.left_out.append(f"{topic} ({direction})")
            else:
                into.append((topic, snapshot.topics.get(topic, "")))
    plumbing = {f"{node}/{name}" for name in PLUMBING_SERVICES}
    for service, nodes in snapshot.services.items():
        if node in nodes:
            if service in plumbing:
                interface.left_out.append(f"{service} (service)")
            else:
                interface.services.append((service, ""))
    return interface


def _with_service_types(master_uri: str, interface: Interface) -> Interface:
    interface.services = [(name, _service_type(master_uri, name)) for name, _ in interface.services]
    return interface


def _service_type(master_uri: str, service: str) -> str:
    """The type of a live service (:func:`.introspect.service_type`: a probe with a timeout, so a hung server
    cannot hang discovery); ``""`` if it cannot be told (its server gone or silent): discovery lists what it can."""
    try:
        return introspect.service_type(master_uri, service)
    except (IpyrosError, OSError):
        return ""
