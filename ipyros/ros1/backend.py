"""ROS 1 as a :class:`~ipyros.node.backend.Backend`: the seam's calls, answered by this package's modules."""

from __future__ import annotations

import io
import sys
from typing import Any, Callable, Optional

from ..core import names
from ..core.errors import IpyrosError, MasterError
from ..core.graph import ROS1_ACTION_TOPICS, GraphSnapshot
from ..core.guard import Guarding
from ..core.model import BaseModel
from ..core.progress import Progress, no_progress
from ..core.qos import Qos
from ..core.records import Interface
from ..core.sessionlink import SessionLink
from ..core.slots import HandlerSlot
from ..processes.basenode import BaseProcess
from . import bagfile, endpoints, introspect, master as master_mod, nodes, params, reconfigure, runtime, services
from .connection import MasterConnection
from .discovery import wait_for_node
from .export import RospyScript
from .graph import fetch_snapshot
from .launch_rest import LaunchBase
from .launchfile import read_base

__all__ = ["Ros1"]


def _actions() -> Any:
    """:mod:`ipyros.ros1.actions`, imported on first use: it needs actionlib (python3-actionlib), which a
    ROS 1 may lack; everything else runs without it."""
    try:
        from . import actions  # noqa: PLC0415 - see the docstring
    except ImportError as error:
        raise IpyrosError(f"actions need actionlib, which this ROS 1 lacks ({error}); "
                          "apt install python3-actionlib") from None
    return actions

Complain = Callable[[str], None]


class Ros1:
    """rospy behind the seam: one process node hosts every DSL node's endpoints; the master is found or started.

    ``host`` (the DSL node's full name) does not matter here: rospy allows one node per
    process, and the names are resolved already.
    """

    name = "ROS 1"
    name_rules = names.ROS1
    #: The QoS fields a declaration's ``qos=`` means something in here (TCP is reliable and ipyros's queues
    #: unbounded: only durability, as latching).
    qos_fields: tuple[str, ...] = ("durability",)

    def __init__(self) -> None:
        self.process = runtime.ProcessNode()
        self.connection = MasterConnection(self.process)
        self._goals: Any = None  # the session's action clients, made with the first goal sent
        self._clock: Optional[runtime.ClockWatch] = None  # a bag's /clock, while its time runs

    @property
    def master(self) -> Any:
        """The master in use (a :class:`~ipyros.ros1.master.MasterHandle`), or None before one is needed."""
        return self.connection.master

    # -- the session's ROS ----------------------------------------------------------------
    def start(self, name: str, session: SessionLink) -> str:
        """Attach to (or start) the master, start the process node as ``name``, watch the master."""
        uri = self.connection.attach(session).uri
        started = self.process.start(session.config.process_node_name or name, uri)
        if name != started:  # a DSL node hosted in the process node: its name must be free too
            runtime.refuse_taken_name(uri, name)
        self.connection.start_watch(session)
        return started

    def connect(self, session: SessionLink, wait: bool = True) -> str:
        """The load line: the master in use; one that answers now is attached, else one is started when allowed
        (in the background unless ``wait``)."""
        connection = self.connection
        if connection.master is not None:
            return connection.master.describe()
        connection.check_config(session, None)
        uri = connection.uri
        if master_mod.answers(uri, timeout=0.3):
            try:
                return connection.attach(session).describe()
            except MasterError as error:  # it went away between the two checks
                return str(error)
        if not session.config.start_master:
            return (f"no ROS master answers at {uri}; start roscore there, "
                    "or let ipyros start one: %config RosMagics.start_master = True")
        if not master_mod.is_this_host(uri):
            return (f"no ROS master answers at {uri}, on another machine; start roscore there (ipyros can start "
                    "one only on this machine), or point ROS_MASTER_URI at this one")
        if wait:
            return connection.attach(session).describe()
        import threading

        def start() -> None:
            try:
                connection.attach(session)
            except Exception as error:  # noqa: BLE001 - a thread must not die silently
                session.notify(f"ipyros: {error}")

        threading.Thread(target=start, name="ipyros-master", daemon=True).start()
        return f"no ROS master answered at {uri}; starting one there (it stops when this session exits)"

    def require_graph(self, doing: str) -> None:
        self.connection.require(doing)

    def check_graph(self) -> None:
        """A master that just restarted: the session registers again before a magic reads the graph."""
        self.connection.check_now()

    def check_config(self, session: SessionLink, master_uri: Optional[str]) -> None:
        self.connection.check_config(session, master_uri)

    def closing(self) -> None:
        self.connection.closing()

    def close(self) -> None:
        self.process.shutdown()
        self.connection.stop()

    def describe(self) -> str:
        master = self.connection.master
        return master.describe() if master is not None else f"ROS master {self.connection.uri} (not attached yet)"

    # -- endpoints -----------------------------------------------------------------------
    # TCPROS is reliable and rospy queues are ipyros's own: of a QoS only durability
    # means something here (transient-local is latched); nothing can mismatch.
    def publication(self, host: str, topic: str, cls: type, qos: Qos, complain: Complain,
                    follows: Optional[str] = None, gate: Optional[Guarding] = None) -> endpoints.Publication:
        return endpoints.Publication(topic, cls, qos.latched, follows, gate)

    def subscription(self, host: str, topic: str, cls: type, slot: HandlerSlot, qos: Qos,
                     complain: Complain) -> endpoints.Subscription:
        return endpoints.Subscription(topic, cls, slot, complain)

    def relay(self, host: str, source: str, target: str, cls: type,
              on_wrong_type: Optional[Callable[[str], None]], complain: Complain, gate: Optional[Guarding] = None) -> endpoints.Relay:
        return endpoints.Relay(source, target, cls, on_wrong_type, complain, gate)

    # -- guards: a message as bytes, the guard's own process -------------------------------------
    @staticmethod
    def serialize(msg: Any) -> bytes:
        buffer = io.BytesIO()
        msg.serialize(buffer)
        return buffer.getvalue()

    @staticmethod
    def sentinel_command() -> list[str]:
        return [sys.executable, "-m", "ipyros.ros1.sentinel"]

    #: TCPROS carries bytes: a topic of a type this Python cannot import is relayed all the same.
    relays_any_type = True
    launch_params_on_server = True  # a launch file's params go on the parameter server, as roslaunch puts them

    def raw_relay(self, host: str, source: str, target: str, type_name: str,
                  on_wrong_type: Optional[Callable[[str], None]], complain: Complain) -> endpoints.RawRelay:
        return endpoints.RawRelay(source, target, type_name, on_wrong_type, complain)

    def timer(self, host: str, period: float, slot: HandlerSlot, oneshot: bool,
              complain: Optional[Complain] = None) -> endpoints.Timer:
        return endpoints.Timer(period, slot, oneshot)  # rospy gives each timer a thread of its own

    def service(self, host: str, name: str, cls: type, slot: HandlerSlot) -> services.ServiceServer:
        return services.ServiceServer(name, cls, slot)

    def service_relay(self, host: str, source: str, target: str, cls: type,
                      complain: Complain) -> services.ServiceRelay:
        return services.ServiceRelay(source, target, cls)  # a basenode's failure reaches the caller as an error

    # -- actions (actionlib: imported when first used, so that a ROS 1 without python3-actionlib runs the rest)
    action_parts: tuple[str, ...] = tuple("/" + part for part in ROS1_ACTION_TOPICS)  # ROS 1 remaps names, one topic each

    def action_server(self, host: str, name: str, cls: type, slot: HandlerSlot, forward: Optional[str]) -> Any:
        return _actions().ActionServer(name, cls, slot, forward)

    def action_relay(self, host: str, source: str, target: str, cls: type,
                     on_wrong_type: Optional[Callable[[str], None]], complain: Complain) -> Any:
        return _actions().ActionRelay(source, target, cls, on_wrong_type, complain)

    def send_goal(self, name: str, cls: type, goal: Any, feedback: Optional[Callable[[Any], None]],
                  timeout: float) -> Any:
        if self._goals is None:
            self._goals = _actions().Goals()
        return self._goals.send(name, cls, goal, feedback, timeout)

    def watch_action(self, name: str, cls: type, tell: Callable[[str, str, Any], None]) -> Any:
        return _actions().ActionWatch(name, cls, tell)

    # -- a bag's time ------------------------------------------------------------------------------
    def bag_time(self, on: bool) -> str:
        """Run on a bag player's ``/clock`` (``on``), or on the wall clock again: ``/use_sim_time`` on the master
        for the basenodes started from now on; ``nd.now()`` reads /clock. What applies, in one line."""
        if on:
            self.set_param("/use_sim_time", True)
            if self._clock is None:
                self._clock = runtime.ClockWatch()
            return ("ipyros: bag time on /clock: nd.now() and the basenodes started from now on run on it; ROS 1 "
                    "has one clock a process, fixed when it starts, so this session's timers keep the wall clock")
        if self._clock is not None:
            self._clock.close()
            self._clock = None
        try:
            if self.has_param("/use_sim_time"):
                self.delete_param("/use_sim_time")
        except (MasterError, OSError):  # the master is gone (the session ends after it): nothing to unset
            pass
        return "ipyros: bag time stopped: /use_sim_time is unset; basenodes started from now on run on the wall clock"

    def now(self, host: str) -> float:
        """ROS time (s): a bag's time while its clock runs, else rospy's."""
        clock = self._clock
        return clock.ns / 1e9 if clock is not None else runtime.ros_time()

    def open_host(self, host: str, parameters: bool = True, complain: Any = None) -> None:
        """Nothing to do: the DSL node's endpoints live in the process node (a namesake: the master ends one)."""

    def close_host(self, host: str) -> None:
        """Nothing to do: the process node stays for the session's other nodes."""

    def closing_hosts(self, hosts: list[str]) -> None:
        """Nothing to do: each subscription has its thread, which closing it ends."""

    # -- the parameter server, by global name --------------------------------------------------
    check_param = staticmethod(params.check_param)
    get_param = staticmethod(params.get_param)
    set_param = staticmethod(params.set_param)
    has_param = staticmethod(params.has_param)
    delete_param = staticmethod(params.delete_param)

    def build_messages(self, package_dir: Any, into: Any, progress: Progress = no_progress) -> list[str]:
        """genpy writes Python only: a moment, no progress to show."""
        from .msggen import build_messages

        return build_messages(package_dir, into)

    def build_types_of(self, node: str, wanted: dict[str, str], progress: Progress = no_progress) -> list[str]:
        """Nothing to build: a ROS 1 relay forwards bytes of any type (a handler needs the package installed)."""
        return []

    def watch_param(self, name: str, tell: Callable[[Any], None]) -> params.ParamWatch:
        return params.ParamWatch(name, tell)

    def forget_params(self, names: list[str]) -> None:
        """Delete what nodes that ended left on the parameter server (a demo robot's launch params)."""
        introspect.forget_params(self.connection.uri, names)

    def refuse_taken_name(self, name: str) -> None:
        runtime.refuse_taken_name(self.connection.uri, name)

    # -- the graph -------------------------------------------------------------------------
    def graph_snapshot(self, timeout: float = 1.0) -> GraphSnapshot:
        return fetch_snapshot(self.connection.uri, timeout)  # never raises: a master down is a snapshot too

    def where(self) -> str:
        return self.connection.uri

    def live_types(self, topics: list[str]) -> dict[str, tuple[str, bool]]:
        """The type each of ``topics`` has on the master, and whether only this process uses it.

        The master remembers a topic's type after everyone left it: only topics with a
        publisher or subscriber now count.
        """
        if self.connection.master is None:
            return {}
        live = self.graph_snapshot(timeout=2.0)
        me = self.process.name
        found = {}
        for topic in topics:
            users = {*live.publishers.get(topic, ()), *live.subscribers.get(topic, ())}
            if live.topics.get(topic):
                found[topic] = (live.topics[topic], users == {me})
        return found

    # -- basenodes, packages, launch files, bags, exports -------------------------------------
    def basenode(self, base: BaseModel, *, log_path: Any = None, on_exit: Any = None) -> BaseProcess:
        """The process of the basenode ``base``: found as rosrun finds it, on the session's master."""
        return BaseProcess(nodes.command(base), node_name=base.node_name, log_path=log_path, on_exit=on_exit,
                           env={**base.env, "ROS_MASTER_URI": self.connection.uri}, control=base.bag is not None)

    own_node_name = staticmethod(nodes.own_node_name)

    def note_link(self, base: BaseModel, process: BaseProcess) -> Optional[str]:
        """Where a package's executable really is, if a link takes it out of the package (rosrun follows it)."""
        return nodes.link_outside(base.package, nodes.find_executable(base.package, base.executable)) \
            if base.package and base.executable else None

    def wait_for_node(self, name: str, timeout: float = 10.0, alive: Optional[Callable[[], bool]] = None,
                      settle: float = 0.5) -> Interface:
        """The interface of the running node ``name``, read from the master once it has settled."""
        return wait_for_node(self.connection.uri, name, timeout=timeout, settle=settle, alive=alive)

    def read_launch(self, launch: Any, node: str, args: Optional[dict[str, Any]]) -> tuple[BaseModel, list[str]]:
        return read_base(launch, node, args)

    def launch_base(self, base: BaseModel, process: BaseProcess, node: str, on_rest_exit: Any) -> Any:
        return LaunchBase(base, process, node=node, master_uri=self.connection.uri, on_rest_exit=on_rest_exit)

    list_packages = staticmethod(nodes.list_packages)
    list_executables = staticmethod(nodes.list_executables)

    def bags(self) -> Any:
        return bagfile

    def export_flavour(self) -> Any:
        return RospyScript

    # -- the graph's services, parameters and nodes, for %services, %call, %params, %nodes ----
    def service_type(self, name: str) -> str:
        uri = introspect.service_uri(self.connection.uri, name)
        return services.served_here(name, uri) or introspect.probe_type(uri, name)

    def call(self, name: str, cls: type, request: Any, timeout: float) -> Any:
        return introspect.call(self.connection.uri, name, cls, request, timeout)

    def params_under(self, namespace: str) -> dict[str, Any]:
        """Every parameter under ``namespace``, by global name."""
        return introspect.params_under(self.connection.uri, namespace)

    read_param = staticmethod(params.get_param)

    def describe_param(self, name: str) -> dict[str, Any]:
        """What ROS 1 knows of a parameter: the type of its value (the parameter server keeps no more), and a
        dynamic_reconfigure server's type, range, default and description when one serves it."""
        server = self._reconfigure_server(name)
        served = reconfigure.describe(server).get(name) if server else None
        if served is not None:
            return {k: v for k, v in served.items() if v not in (None, "")}
        return {"type": type(self.read_param(name)).__name__}

    def param_ranges(self, namespace: str) -> dict[str, str]:
        """``{global name: "double 0..10"}`` for the parameters under ``namespace`` that a dynamic_reconfigure
        server serves (%params shows them in a column of their own)."""
        found: dict[str, str] = {}
        for server in reconfigure.servers(self.graph_snapshot().topics, namespace):
            try:
                found.update({name: reconfigure.range_text(d) for name, d in reconfigure.describe(server).items()})
            except IpyrosError:  # a server that does not answer: its values are listed all the same
                continue
        return found

    def _reconfigure_server(self, name: str) -> Optional[str]:
        """The node owning parameter ``name`` if it is a dynamic_reconfigure server of the graph."""
        server = name.rsplit("/", 1)[0]
        return server if reconfigure.is_server(self.graph_snapshot().topics, server) else None

    @staticmethod
    def size_note(size: float) -> Optional[str]:
        """Nothing to say: TCPROS carries a message of any size in one piece."""
        return None

    #: Parameters every node has, which %params leaves out unless asked: none on ROS 1.
    standard_params: tuple[str, ...] = ()

    def write_param(self, name: str, value: Any) -> Any:
        """Set the parameter ``name``: through its dynamic_reconfigure server when one serves it (the running
        node reads the parameter server only at start), else on the parameter server; the value set."""
        server = self._reconfigure_server(name)
        kept = reconfigure.set_value(server, name.rsplit("/", 1)[1], value) if server else None
        if kept is not None:
            return kept
        params.set_param(name, value)
        return value

    def topic_endpoints(self, topic: str) -> list[tuple[str, str, str, str]]:
        """Who publishes and subscribes to ``topic``, each with its type (``%topics -v``)."""
        return introspect.topic_endpoints(self.connection.uri, topic)

    def node_pid(self, node: str) -> Optional[int]:
        return introspect.node_pid(self.connection.uri, node)

    def lifecycle(self, node: str, transition: Optional[str] = None) -> tuple[str, list[str]]:
        raise IpyrosError("managed (lifecycle) nodes are ROS 2's; ROS 1 nodes run from start to end")

    def node_connections(self, node: str) -> list[tuple[str, str, str, str]]:
        return introspect.node_connections(self.connection.uri, node)

    def ping_node(self, node: str) -> float:
        return introspect.ping_node(self.connection.uri, node)

    def kill_node(self, node: str) -> None:
        introspect.kill_node(self.connection.uri, node)

    def cleanup_nodes(self) -> list[str]:
        return introspect.cleanup_nodes(self.connection.uri)

    def __repr__(self) -> str:
        return f"<ipyros backend {self.name}: {self.process.name or 'no node yet'}>"
