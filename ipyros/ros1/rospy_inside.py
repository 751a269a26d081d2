"""rospy's internals, behind one door: every place ipyros reaches past rospy's public API, what it does there, why.

The rest of ``ros1/`` calls the functions here; nothing else patches rospy or reads its private
parts. Written against ros_comm 1.15 (Debian bookworm's); :func:`check` says in one line, naming
rospy's version, if rospy's shape is not the one these rely on (tested, so that a change of
rospy fails loudly in the suite instead of quietly at a prompt).

What is patched (on ipyros's own objects only: the session's subscriptions and their connections)

1. a subscription's ``remove_connection`` (:func:`on_connection_removed`): rospy ignores a
   publisher update while the old connection to that publisher is still listed, then drops the
   connection, and the publisher is lost for good; the session asks the master again after a
   connection ends (``reconnect.Reconnect``).
2. a subscription's ``add_connection`` and each connection protocol's ``read_messages``
   (:func:`on_connection_added`, :func:`take_over_reading`): a large message is read straight into
   one buffer and relayed while it arrives (:mod:`.cutthrough`).
3. the caller id and the registration handler's name (:func:`rename_caller`): a helper started
   first (``%echo``) hands its rospy node to the first DSL node, under that node's name.

What is read (private, not changed)

4. the text of rospy's internal log (:func:`listen_to_internal_log`): rospy says that a peer's type
   differs only there, and ipyros tells the user who and what (``endpoints._OtherTypes``);
5. the stack frame of rospy's connecting thread (:func:`connecting_topic`): that log line does not
   name the topic, the thread that logged it holds it;
6. rospy's registration state (:func:`topic_manager`, :func:`service_manager`,
   :func:`registration_manager`, :func:`node_uri`) and its logger services: what the process has
   registered, to register it again after a master restart or under a new name, and the type of a
   service it serves itself (``services.served_here``: no probe through its own socket);
7. a publication's and a subscription's impl (:func:`impl_of`; a publication's ``acquire``, ``publish``,
   ``release``, ``enable_latch``, both's ``connections``): bytes are written as they came, without rospy's type
   check (relays and exported relays), and a relay counts its connections;
8. the parameter cache's notifier (:func:`notify_param_sets`, set, the one patch of a rospy-wide
   object): the master pushes a parameter set from outside to the process that subscribed to it
   (``on_param``), and rospy tells only that notifier;
9. how rospy turns a service handler's return value into a response (:func:`response_of`): a
   handler may return a response, a tuple, a dict or a value, as it may in rospy.
"""

from __future__ import annotations

import functools
import inspect
import logging
import sys
from typing import Any, Callable, Optional

import rospy

__all__ = ["RospyShapeError", "check", "connecting_topic", "listen_to_internal_log", "logger_services", "node_uri",
           "impl_of", "initialised_or_ended", "notify_param_sets", "on_connection_added", "on_connection_removed", "registration_manager",
           "rename_caller", "response_of", "rospy_version", "service_manager", "subscriber_impl",
           "take_over_reading", "topic_manager"]


class RospyShapeError(RuntimeError):
    """rospy is not shaped as this module relies on (another ros_comm than 1.15)."""


def rospy_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("rospy")
    except PackageNotFoundError:
        return "of unknown version"


# -- 1, 2: a subscription's connections -------------------------------------------------------

def on_connection_removed(sub_impl: Any, call: Callable[[], None]) -> None:
    """Have ``call()`` run after each connection of ``sub_impl`` (a ``_SubscriberImpl``) ends while it stays open."""
    if getattr(sub_impl, "_ipyros_removed", False):
        return
    original = sub_impl.remove_connection

    def remove_connection(connection: Any) -> None:
        original(connection)
        if not sub_impl.closed:
            call()

    sub_impl.remove_connection = remove_connection  # what rospy hands each new connection as its cleanup
    sub_impl._ipyros_removed = True


def on_connection_added(sub_impl: Any, call: Callable[[Any], None]) -> None:
    """Have ``call(connection)`` run on each connection of ``sub_impl``, now and as they are added."""
    add_connection = sub_impl.add_connection

    def add_and_call(connection: Any) -> bool:
        call(connection)
        return add_connection(connection)

    sub_impl.add_connection = add_and_call
    for connection in list(sub_impl.connections):
        call(connection)


def take_over_reading(connection: Any, read_messages: Callable[..., None]) -> None:
    """Have ``read_messages(connection, rospy_own, b, msg_queue, sock)`` find the whole messages of ``connection``
    in what it has read, in place of its protocol's own (once)."""
    protocol = connection.protocol
    if "read_messages" not in protocol.__dict__:
        protocol.read_messages = functools.partial(read_messages, connection, protocol.read_messages)


def impl_of(endpoint: Any) -> Any:
    """A rospy Publisher's or Subscriber's impl, shared by every endpoint of its topic in this process (7): its
    ``connections``, a publication's lock (``acquire``, ``release``), latch (``is_latch``, ``enable_latch``,
    ``latch``) and bytes written as they came (``publish``), a subscription's ``callbacks``."""
    return endpoint.impl


def subscriber_impl(topic: str) -> Any:
    """This process's subscription of ``topic`` (rospy keeps one per topic), or None."""
    return rospy.topics.get_topic_manager().get_subscriber_impl(topic)


# -- 3, 6: the process's registration ----------------------------------------------------------

def topic_manager() -> Any:
    from rospy.impl.registration import get_topic_manager

    return get_topic_manager()


def service_manager() -> Any:
    from rospy.impl.registration import get_service_manager

    return get_service_manager()


def registration_manager() -> Any:
    """rospy's RegManager: given a topic's publishers, it connects to those it lacks."""
    from rospy.impl.registration import RegManager, get_registration_listeners

    return next((listener for listener in get_registration_listeners().listeners
                 if isinstance(listener, RegManager)), None)


def initialised_or_ended() -> bool:
    """Whether rospy's one node of this process was started (or shut down) already: there can be no other."""
    return rospy.core.is_shutdown_requested() or rospy.core.is_initialized()


def node_uri() -> str:
    """This process's XML-RPC address (what the master knows it by, whatever its name)."""
    return rospy.core.get_node_uri()


def rename_caller(name: str) -> None:
    """Go on as ``name``: rospy's caller id, and the name its XML-RPC handler answers ``getName`` with."""
    rospy.names._set_caller_id(name)
    manager = registration_manager()
    if manager is not None:
        manager.handler.name = name


def logger_services() -> tuple[Callable[..., Any], Callable[..., Any]]:
    """rospy's own ``~get_loggers`` and ``~set_logger_level`` handlers (served again under a new name)."""
    from rospy.client import _get_loggers, _set_logger_level

    return _get_loggers, _set_logger_level


# -- 4, 5: what rospy only logs ----------------------------------------------------------------

def listen_to_internal_log(handler: logging.Handler) -> None:
    """Hand ``handler`` what rospy writes to its internal log (a peer of another type is said only there)."""
    logging.getLogger("rospy.internal").addHandler(handler)


def connecting_topic() -> Optional[str]:
    """The topic rospy's connecting thread (``robust_connect_subscriber``, on the stack of the calling thread) is
    connecting: the publisher's "topic types do not match" answer, which that thread logs, does not name it."""
    frame = sys._getframe(1)
    while frame is not None:
        if frame.f_code.co_name == "robust_connect_subscriber":
            return frame.f_locals.get("resolved_topic_name")
        frame = frame.f_back
    return None


# -- 8, 9: parameters set from outside, services' answers ----------------------------------------

def notify_param_sets(notify: Callable[[str, Any], None]) -> None:
    """Have ``notify(key, value)`` told of each parameter the master pushes to this process (those it subscribed
    to with ``get_param_cached``)."""
    from rospy.impl.paramserver import get_param_server_cache

    get_param_server_cache().set_notifier(notify)


def response_of(result: Any, response_class: type) -> Any:
    """A service handler's return value as rospy makes it a response (a response, a tuple, a dict, a value)."""
    from rospy.impl.tcpros_service import convert_return_to_response

    return convert_return_to_response(result, response_class)


# -- the shape relied on -------------------------------------------------------------------------

def _shape() -> list[tuple[str, Callable[[], bool]]]:
    """(what, whether rospy has it as ipyros uses it), for each item of the module's list."""
    from rospy.impl import registration, tcpros_base, tcpros_pubsub

    sub, pub = rospy.topics._SubscriberImpl, rospy.topics._PublisherImpl

    def has(obj: Any, *names: str) -> Callable[[], bool]:
        return lambda: all(hasattr(obj, name) for name in names)

    return [
        ("_SubscriberImpl.add_connection and remove_connection (1, 2)", has(sub, "add_connection",
                                                                          "remove_connection")),
        ("TCPROSTransportProtocol.read_messages(b, msg_queue, sock) (2)",
         lambda: list(inspect.signature(tcpros_base.TCPROSTransportProtocol.read_messages).parameters)
         == ["self", "b", "msg_queue", "sock"]),
        ("rospy.names._set_caller_id (3)", has(rospy.names, "_set_caller_id")),
        ("registration's RegManager, get_registration_listeners, get_topic_manager, get_service_manager (3, 6)",
         has(registration, "RegManager", "get_registration_listeners", "get_topic_manager", "get_service_manager")),
        ("the 'rospy.internal' logger (4)", lambda: "rospy.internal" in logging.Logger.manager.loggerDict),
        ("tcpros_pubsub.robust_connect_subscriber with a local resolved_topic_name (5)",
         lambda: "resolved_topic_name" in tcpros_pubsub.robust_connect_subscriber.__code__.co_varnames),
        ("rospy.core.get_node_uri, is_shutdown, is_initialized, is_shutdown_requested (6)",
         has(rospy.core, "get_node_uri", "is_shutdown", "is_initialized", "is_shutdown_requested")),
        ("rospy.client._get_loggers and _set_logger_level (6)", has(rospy.client, "_get_loggers",
                                                                  "_set_logger_level")),
        ("_PublisherImpl.acquire, release, publish, enable_latch (7)",
         has(pub, "acquire", "release", "publish", "enable_latch")),
        ("paramserver's get_param_server_cache().set_notifier (8)",
         lambda: hasattr(__import__("rospy.impl.paramserver", fromlist=["x"]).get_param_server_cache(),
                         "set_notifier")),
        ("tcpros_service.convert_return_to_response (9)",
         has(__import__("rospy.impl.tcpros_service", fromlist=["x"]), "convert_return_to_response")),
    ]


def check() -> None:
    """Raise :class:`RospyShapeError`, naming rospy's version and what is missing, if rospy is not shaped as this
    module relies on."""
    missing = []
    for what, present in _shape():
        try:
            ok = present()
        except Exception:  # noqa: BLE001 - a part that is not there at all
            ok = False
        if not ok:
            missing.append(what)
    if missing:
        raise RospyShapeError(f"rospy {rospy_version()} is not shaped as ipyros's ros1/rospy_inside.py relies on "
                              f"(written for ros_comm 1.15): no {'; no '.join(missing)}")
