"""A subscription connected again when one of its connections ends while its publisher is still there: rospy
would lose that publisher for good (see :class:`Reconnect`); the master is asked again for the topic's
publishers."""

from __future__ import annotations

import os
import threading
import xmlrpc.client
from typing import Any

import rospy

from . import rospy_inside
from .master import master_proxy

__all__ = ["Reconnect", "subscribe_again"]


def subscribe_again(master: Any, manager: Any, topic: str, type_name: str) -> None:
    """Register the subscription of ``topic`` with the master; rospy connects to the publishers it lacks."""
    code, _, publishers = master.registerSubscriber(rospy.get_name(), topic, type_name, rospy_inside.node_uri())
    if code == 1 and manager is not None:
        manager.publisher_update(topic, publishers)


class Reconnect:
    """Connect a subscription again when one of its connections ends while its publisher is still there.

    rospy loses a publisher for good when the connection to it ends but the master's
    update about that publisher came while the old connection was still listed (a node
    that re-advertises quickly, one that starts up as another of the same URI goes): the
    update is ignored as "already connected", then the connection goes. So whenever a
    connection of a subscription of this process ends, the master is asked a moment later
    for the topic's publishers, and rospy connects to those it lacks; and asked again
    :data:`AGAIN` times a second apart, as a connection that ends while a first ask is pending
    starts no ask of its own. A publisher that is really gone is not listed any more, and
    nothing happens.
    """

    _pending: set[str] = set()
    _lock = threading.Lock()
    #: How many times the master is asked again after the first ask, a second apart.
    AGAIN = 2

    @classmethod
    def guard(cls, subscriber: Any) -> None:
        impl = rospy_inside.impl_of(subscriber)
        rospy_inside.on_connection_removed(impl, lambda: cls._soon(impl))

    @classmethod
    def _soon(cls, impl: Any) -> None:
        with cls._lock:
            if impl.resolved_name in cls._pending:
                return
            cls._pending.add(impl.resolved_name)
        cls._later(0.3, impl, cls.AGAIN)

    @classmethod
    def _later(cls, delay: float, impl: Any, left: int) -> None:
        timer = threading.Timer(delay, cls._ask, (impl, left))
        timer.daemon = True
        timer.start()

    @classmethod
    def _ask(cls, impl: Any, left: int) -> None:
        """Register the subscription again, unless it closed meanwhile (its node shut down as its publisher went):
        a closed subscription registered again would be left on the master as a dead entry."""
        topic = impl.resolved_name
        if left == cls.AGAIN:  # the first ask: a connection that ends from now on asks anew
            with cls._lock:
                cls._pending.discard(topic)
        manager = rospy_inside.registration_manager()
        if manager is None or rospy.is_shutdown() or impl.closed:
            return
        try:
            master = master_proxy(os.environ.get("ROS_MASTER_URI", ""), timeout=2.0)
            subscribe_again(master, manager, topic, impl.type)
            if impl.closed:  # it closed while it was being registered: take it back
                master.unregisterSubscriber(rospy.get_name(), topic, rospy_inside.node_uri())
                return
        except (OSError, xmlrpc.client.Error):
            return  # no master now: when it is back, the master watch registers everything again
        if left > 0:
            cls._later(1.0, impl, left - 1)
