"""QoS in rclpy's terms: a :class:`~ipyros.core.qos.Qos` as rclpy's profile and back, a peer's QoS in words, and
the one line said when two endpoints' QoS keep them apart (ROS 2 connects nothing between incompatible QoS and only
logs a warning)."""

from __future__ import annotations

import threading
from typing import Any, Callable, Optional

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, LivelinessPolicy, QoSProfile, ReliabilityPolicy

from ..core.qos import Qos

__all__ = ["Complain", "mismatch_report", "peer_name", "profile_of", "qos_of", "qos_text"]

#: Reliable, and deep enough that a burst is not cut short: what ROS 1's unbounded
#: subscriber queue gave. A declaration's ``qos=`` overrides any of it.
_DEPTH = 1000


Complain = Callable[[str], None]


def profile_of(qos: Qos = Qos()) -> QoSProfile:
    """rclpy's profile for ``qos``; what it leaves out is reliable, volatile, depth 1000
    (depth 1 when transient-local: the last message, as a ROS 1 latched topic)."""
    return QoSProfile(depth=qos.depth or (1 if qos.latched else _DEPTH),
                      reliability=ReliabilityPolicy.BEST_EFFORT if qos.reliability == "best_effort"
                      else ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL if qos.latched else DurabilityPolicy.VOLATILE)


def qos_of(profile: Any) -> Qos:
    """The :class:`Qos` a peer's profile (from the graph) amounts to."""
    return Qos(profile.depth or None,
               "best_effort" if profile.reliability == ReliabilityPolicy.BEST_EFFORT else "reliable",
               "transient_local" if profile.durability == DurabilityPolicy.TRANSIENT_LOCAL else "volatile")


def qos_text(profile: Any) -> str:
    """A peer's QoS in words, for ``%topics -v``: reliability, durability, depth, and the deadline, lifespan and
    liveliness where they are not the defaults (a deadline or a manual liveliness also decides what matches)."""
    words = [str(qos_of(profile))]
    for what, duration in (("deadline", profile.deadline), ("lifespan", profile.lifespan)):
        if 0 < duration.nanoseconds < (1 << 63) - 1:
            words.append(f"{what} {duration.nanoseconds / 1e9:g} s")
    if profile.liveliness not in (LivelinessPolicy.AUTOMATIC, LivelinessPolicy.SYSTEM_DEFAULT):
        lease = profile.liveliness_lease_duration.nanoseconds
        words.append(f"liveliness {profile.liveliness.name.lower().replace('_', '-')}" +
                     (f" lease {lease / 1e9:g} s" if 0 < lease < (1 << 63) - 1 else ""))
    return " ".join(words)


_MATCH_ADVICE = {
    "reliability": "a best-effort publisher reaches only best-effort subscriptions: subscribe with "
                   "qos='best_effort' (or 'sensor_data'), or publish reliable",
    "durability": "a transient-local subscription needs a transient-local publisher: subscribe volatile "
                  "(the default), or publish with qos='transient_local' (or latch=True)",
}


def peer_name(namespace: str, name: str) -> Optional[str]:
    """A peer endpoint's node as ``/ns/name``, or None while discovery has not told it (rclpy then gives
    ``_NODE_NAMESPACE_UNKNOWN_`` and ``_NODE_NAME_UNKNOWN_``)."""
    if "_UNKNOWN_" in name or "_UNKNOWN_" in namespace:
        return None
    return f"{namespace.rstrip('/')}/{name}"


def mismatch_report(node: Node, topic: str, mine: Qos, what: str, complain: Optional[Complain]) -> Any:
    """Event callbacks that say, in one line, which peer's QoS keeps it from connecting.

    ROS 2 connects nothing between incompatible QoS and only logs a warning; this puts
    the mismatch, the peer and the declaration that would match it in front of the user.
    """
    from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
    from rclpy.qos import qos_policy_name_from_kind

    if complain is None:
        return None
    peers_of = node.get_subscriptions_info_by_topic if what == "publication" else node.get_publishers_info_by_topic
    peer_kind = "subscription" if what == "publication" else "publisher"

    here = qos_of(profile_of(mine))

    def report(event: Any, final: bool = False) -> None:
        policy = qos_policy_name_from_kind(event.last_policy_kind).lower()
        peers = [(peer_name(info.node_namespace, info.node_name), qos_of(info.qos_profile)) for info in peers_of(topic)]
        peers = [(name, theirs) for name, theirs in peers
                 if (theirs.reliability, theirs.durability) != (here.reliability, here.durability)]
        if not final and any(name is None for name, _ in peers):
            # The event can come before discovery has told which node the peer endpoint is: look again shortly.
            later = threading.Timer(1.0, report, args=(event, True))
            later.daemon = True
            later.start()
            return
        others = [f"{name or 'a node not known yet (discovery is still under way)'} "
                  f"({theirs.reliability.replace('_', '-')} {theirs.durability.replace('_', '-')})"
                  for name, theirs in peers]
        complain(f"{topic}: the {what} here ({here.reliability.replace('_', '-')} "
                 f"{here.durability.replace('_', '-')}) and a {peer_kind} of "
                 f"{', '.join(others) or 'another node'} have incompatible {policy}: nothing passes between them; "
                 f"{_MATCH_ADVICE.get(policy, 'declare qos= to match')}")

    if what == "publication":
        return PublisherEventCallbacks(incompatible_qos=report)
    return SubscriptionEventCallbacks(incompatible_qos=report)
