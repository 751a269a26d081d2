"""The session's rospy node (the ROS 1 backend's runtime): the one ROS node of this process, its logging, its name.

Other modules of ``ros1/`` talk to rospy too (actions, bags, introspection, the master); what
reaches past rospy's public API goes through :mod:`.rospy_inside` alone. rospy allows one ROS
node per process. :class:`ProcessNode` is that node; every DSL
node of the session hosts its publishers, subscribers, relays, timers and services in
it.

Its endpoints are in :mod:`ipyros.ros1.endpoints`, the parameter server in :mod:`ipyros.ros1.params`, a
subscription connected again when rospy would lose its publisher in :mod:`ipyros.ros1.reconnect`.
"""

from __future__ import annotations

import logging
import os
import sys
import threading
import xmlrpc.client
from typing import Any, Optional

import rospy

from ..core.errors import MasterError, NodeStateError
from ..core.names import is_tool
from . import rospy_inside
from .master import master_proxy
from .reconnect import subscribe_again

__all__ = ["ClockWatch", "ProcessNode", "refuse_taken_name", "ros_time"]


class ProcessNode:
    """The rospy node of this process, started once and shared by every DSL node."""

    #: Whether the session's DSL nodes share one ROS node, which the graph shows: here, yes.
    shared = True

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.name: Optional[str] = None  # global name, once started
        self.master_uri: Optional[str] = None

    @property
    def started(self) -> bool:
        return self.name is not None

    def start(self, name: str, master_uri: str) -> str:
        """Start the process node as ``name`` (a global name) unless it already runs.

        A process node that one of ipyros's helpers started (``%echo`` before any ``create()``)
        takes the name of the first node the user creates: the user's node keeps its name
        whatever ran first.
        """
        with self._lock:
            if self.name is not None:
                if is_tool(self.name) and not is_tool(name):
                    self._rename(name)
                return self.name
            if rospy_inside.initialised_or_ended():
                raise NodeStateError("rospy was already initialised or shut down in this process; "
                                     "restart the interpreter to use ipyros")
            refuse_taken_name(master_uri, name)
            os.environ["ROS_MASTER_URI"] = master_uri
            namespace, base = name.rsplit("/", 1)
            # Signals stay IPython's: Ctrl-C must interrupt the prompt, not kill the node.
            rospy.init_node(base, argv=[f"__ns:={namespace or '/'}"], disable_signals=True)
            _python_warnings_still_shown()
            self.name, self.master_uri = rospy.get_name(), master_uri
            return self.name

    def _rename(self, name: str) -> None:
        """Go on as ``name``: every registration moves from the old name to the new one.

        rospy cannot start a second node in a process, but a node is, to the master and its
        peers, a caller id and an XML-RPC address: the address stays, the caller id changes.
        Connections made already stay up (peers find the same address under the new name).
        """
        from roscpp.srv import GetLoggers, SetLoggerLevel

        refuse_taken_name(self.master_uri, name)
        old, uri = self.name, rospy_inside.node_uri()
        master = master_proxy(self.master_uri, timeout=5.0)
        services = rospy_inside.service_manager()
        for service, _ in services.get_services():  # rospy's own, named after the node: named again below
            if service in (f"{old}/get_loggers", f"{old}/set_logger_level"):
                services.get_service(service).shutdown()
        topics = rospy_inside.topic_manager()
        for topic, _ in topics.get_publications():
            master.unregisterPublisher(old, topic, uri)
        for topic, _ in topics.get_subscriptions():
            master.unregisterSubscriber(old, topic, uri)
        for service, service_uri in services.get_services():
            master.unregisterService(old, service, service_uri)
        rospy_inside.rename_caller(name)
        get_loggers, set_logger_level = rospy_inside.logger_services()
        rospy.Service(f"{name}/get_loggers", GetLoggers, get_loggers)
        rospy.Service(f"{name}/set_logger_level", SetLoggerLevel, set_logger_level)
        self.name = name
        self.register_again()

    def register_again(self) -> tuple[int, int, int]:
        """Tell a restarted master every publication, subscription and service of this process.

        What rospy's registration thread does once at start, done again: subscriptions get
        the master's list of publishers back, and rospy connects to them. Returns how many
        publications, subscriptions and services were registered.
        """
        topics, services = rospy_inside.topic_manager(), rospy_inside.service_manager()
        manager = rospy_inside.registration_manager()
        master, caller, uri = master_proxy(self.master_uri, timeout=5.0), rospy.get_name(), rospy_inside.node_uri()
        publications, subscriptions = topics.get_publications(), topics.get_subscriptions()
        for name, type_name in publications:
            master.registerPublisher(caller, name, type_name, uri)
        for name, type_name in subscriptions:
            subscribe_again(master, manager, name, type_name)
        served = services.get_services()
        for name, service_uri in served:
            master.registerService(caller, name, service_uri, uri)
        return len(publications), len(subscriptions), len(served)

    def shutdown(self, reason: str = "ipyros exit") -> None:
        if self.name is not None and not rospy.is_shutdown():
            rospy.signal_shutdown(reason)

    @staticmethod
    def master_gone() -> None:
        """The master is gone and the session is closing: rospy's warning that it could not
        unregister, printed once per endpoint, tells nothing then (there is nothing to unregister from)."""
        logging.getLogger("rosout").addFilter(_no_out_of_sync)


def _no_out_of_sync(record: logging.LogRecord) -> bool:
    return "registrations are now out of sync" not in record.getMessage()


class _Stderr(logging.StreamHandler):
    """A handler that writes to ``sys.stderr`` as it is now (IPython, Jupyter and tests replace it)."""

    @property  # type: ignore[override]
    def stream(self) -> Any:
        return sys.stderr

    @stream.setter
    def stream(self, value: Any) -> None:
        pass


class _NotRos(logging.Filter):
    """Records of every logger but ROS's own (which rospy sends to /rosout and its log file)."""

    ROS = ("rospy", "rosout", "rosgraph", "roslaunch", "rosmaster", "rosbag", "topic_tools")

    def filter(self, record: logging.LogRecord) -> bool:
        return not record.name.startswith(self.ROS)


def _python_warnings_still_shown() -> None:
    """Give Python's warnings and errors a way to the user again after ``rospy.init_node``.

    rospy configures logging for the whole process: the root logger gets its log file as
    its only handler, so what IPython, traitlets or any library logs (``%config`` refusing a
    value, say) went to ``~/.ros/log`` and the user saw nothing. A handler on stderr, for
    warnings and up from every logger but ROS's own, gives them back what Python's
    ``lastResort`` gave them before rospy started.
    """
    root = logging.getLogger()
    if any(isinstance(f, _NotRos) for h in root.handlers for f in h.filters):
        return
    shown = _Stderr()
    shown.setLevel(logging.WARNING)
    shown.addFilter(_NotRos())
    shown.setFormatter(logging.Formatter("%(levelname)s:%(name)s:%(message)s"))
    root.addHandler(shown)


def refuse_taken_name(master_uri: str, name: str) -> None:
    """Refuse a node name a live node has: the master would kill that node (or, for a DSL node
    hosted in the process node, ``rosnode info`` of the name would show the other one)."""
    try:
        code, _, api = master_proxy(master_uri).lookupNode("/ipyros", name)
    except OSError as error:
        raise MasterError(f"cannot reach the ROS master at {master_uri} ({error.strerror or error}); "
                          "start roscore or unset ROS_MASTER_URI to let ipyros start one") from None
    if code != 1:
        return
    try:
        master_proxy(api, timeout=1.0).getPid("/ipyros")
    except (OSError, xmlrpc.client.Error):
        return  # a stale registration: taking the name over is harmless
    raise NodeStateError(f"a node named {name} is already running; give this node another name "
                         "(taking the name would make the master shut the other one down)")


def ros_time() -> float:
    """This process's ROS time (s): rospy's clock."""
    return rospy.get_rostime().to_sec()


class ClockWatch:
    """The time a bag's player publishes on ``/clock``: this process's rospy clock is fixed when rospy starts
    (wall time, unless ``/use_sim_time`` was set before), so bag time is read here for ``nd.now()``."""

    def __init__(self) -> None:
        from rosgraph_msgs.msg import Clock

        self.ns = 0  # ROS's rule: time is 0 until the first /clock
        self._sub = rospy.Subscriber("/clock", Clock, self._heard, queue_size=1, tcp_nodelay=True)

    def _heard(self, msg: Any) -> None:
        self.ns = msg.clock.to_nsec()

    def close(self) -> None:
        self._sub.unregister()
