"""ROS 2 as a :class:`~ipyros.node.backend.Backend`: the seam's calls, answered by :mod:`.runtime`."""

from __future__ import annotations

import dataclasses
import os
import sys
import time
from typing import Any, Callable, Optional

from rclpy._rclpy_pybind11 import RCLError
from rclpy.exceptions import NameValidationException

from ..core import msgtypes, names
from ..core.errors import DeclarationError, IpyrosError, MessageTypeError, NodeStateError, first_line
from ..core.graph import GraphSnapshot
from ..core.guard import Guarding
from ..core.model import BaseModel
from ..core.progress import Progress, no_progress
from ..core.qos import Qos
from ..core.records import Interface
from ..core.sessionlink import SessionLink
from ..core.slots import HandlerSlot
from ..processes.basenode import BaseProcess
from . import actions, bagfile, endpoints, fastdds, graph, introspect, launchfile, nodes, params, qosmatch, runtime
from .export import RclpyScript
from .launch_rest import LaunchBase
from .qosmatch import Complain

__all__ = ["Ros2"]


class Ros2:
    """rclpy behind the seam: each DSL node (``host``) is a ROS 2 node of its own."""

    name = "ROS 2"
    name_rules = names.ROS2
    #: The QoS fields a declaration's ``qos=`` means something in: all of them.
    qos_fields: tuple[str, ...] = ("depth", "reliability", "durability")

    def __init__(self) -> None:
        #: Which Fast DDS configuration this session (and what it starts) runs with, in words.
        self.transport = fastdds.prepare()  # before rclpy starts, and before any child is started
        fastdds.remove_stale_files()  # what killed processes left would hide this session's nodes
        self.process = runtime.ProcessNode()
        self._goals: Optional[actions.Goals] = None  # the session's action clients, made with the first goal sent

    # -- the session's ROS: no master; peers find each other in the DDS domain -------------
    def start(self, name: str, session: SessionLink) -> str:
        return self.process.start(session.config.process_node_name or name)

    def connect(self, session: SessionLink, wait: bool = True) -> str:
        return self.describe()

    def require_graph(self, doing: str) -> None:
        """Nothing to require: there is no master to be gone."""

    def check_graph(self) -> None:
        """Nothing to check: discovery keeps itself up to date."""

    def check_config(self, session: SessionLink, master_uri: Optional[str]) -> None:
        """Nothing to check: a master URI means nothing on ROS 2."""

    def closing(self) -> None:
        """Nothing to do before the nodes shut down."""

    def close(self) -> None:
        if self._goals is not None:  # before their node: an action client left over keeps the participant alive
            self._goals.close()      # past the process's end, and its Fast DDS ports with it
            self._goals = None
        self.process.shutdown()

    def publication(self, host: str, topic: str, cls: type, qos: Qos, complain: Complain,
                    follows: Optional[str] = None, gate: Optional[Guarding] = None) -> endpoints.Publication:
        return endpoints.Publication(self.process.host(host), topic, cls, qos, complain, self.process, follows, gate)

    def subscription(self, host: str, topic: str, cls: type, slot: HandlerSlot, qos: Qos,
                     complain: Complain) -> endpoints.Subscription:
        return endpoints.Subscription(self.process, self.process.host(host), topic, cls, slot, qos, complain)

    def relay(self, host: str, source: str, target: str, cls: type,
              on_wrong_type: Optional[Callable[[str], None]], complain: Complain, gate: Optional[Guarding] = None) -> endpoints.Relay:
        return endpoints.Relay(self.process, self.process.host(host), source, target, cls, on_wrong_type, complain,
                             gate=gate)

    # -- guards: a message as bytes, the guard's own process -------------------------------------
    @staticmethod
    def serialize(msg: Any) -> bytes:
        from rclpy.serialization import serialize_message

        return serialize_message(msg)

    @staticmethod
    def sentinel_command() -> list[str]:
        return [sys.executable, "-m", "ipyros.ros2.sentinel"]

    #: rclpy needs the type's Python package to subscribe at all, even to bytes.
    relays_any_type = False
    launch_params_on_server = False  # a launch file's params go on the basenode's command line

    def raw_relay(self, host: str, source: str, target: str, type_name: str,
                  on_wrong_type: Optional[Callable[[str], None]], complain: Complain) -> Any:
        raise MessageTypeError(f"ROS 2 relays only types this Python has; install {type_name.split('/')[0]} "
                               f"({msgtypes.install_hint(type_name.split('/')[0])})")

    def timer(self, host: str, period: float, slot: HandlerSlot, oneshot: bool,
              complain: Optional[Complain] = None) -> endpoints.Timer:
        return endpoints.Timer(self.process.host(host), period, slot, oneshot, complain, self.process.spinner)

    def service(self, host: str, name: str, cls: type, slot: HandlerSlot) -> endpoints.ServiceServer:
        return endpoints.ServiceServer(self.process.host(host), name, cls, slot)

    def service_relay(self, host: str, source: str, target: str, cls: type,
                      complain: Complain) -> endpoints.ServiceRelay:
        return endpoints.ServiceRelay(self.process, self.process.host(host), source, target, cls, complain)

    # -- actions: an action is remapped by its name, as a whole ------------------------------
    action_parts: tuple[str, ...] = ("",)

    def action_server(self, host: str, name: str, cls: type, slot: HandlerSlot,
                      forward: Optional[str]) -> actions.ActionServer:
        return actions.ActionServer(self.process, self.process.host(host), name, cls, slot, forward)

    def action_relay(self, host: str, source: str, target: str, cls: type,
                     on_wrong_type: Optional[Callable[[str], None]], complain: Complain) -> actions.ActionRelay:
        return actions.ActionRelay(self.process, self.process.host(host), source, target, cls, on_wrong_type,
                                   complain)

    def send_goal(self, name: str, cls: type, goal: Any, feedback: Optional[Callable[[Any], None]],
                  timeout: float) -> actions.Goal:
        if self._goals is None:
            self._goals = actions.Goals(self.process.caller())
        return self._goals.send(name, cls, goal, feedback, timeout)

    def watch_action(self, name: str, cls: type, tell: Callable[[str, str, Any], None]) -> actions.ActionWatch:
        return actions.ActionWatch(self.process.caller(), name, cls, tell)

    def wait_for_node(self, name: str, timeout: float = 10.0, alive: Optional[Callable[[], bool]] = None,
                      settle: float = 0.5) -> Interface:
        """The interface of the running node ``name`` once it has settled."""
        return graph.wait_for_node(self._graph(), name, timeout, settle=settle, alive=alive)

    # -- a bag's time ------------------------------------------------------------------------------
    def bag_time(self, on: bool) -> str:
        """Run the session's nodes on a bag player's ``/clock`` (``on``: their use_sim_time, and the basenodes
        started from now on), or on the system clock again. What applies, in one line."""
        self.process.use_sim_time(on)
        if on:
            return ("ipyros: bag time on /clock: the session's nodes (nd.now(), their timers) and the basenodes "
                    "started from now on run on it")
        return "ipyros: bag time stopped: the session's nodes run on the system clock again"

    def now(self, host: str) -> float:
        return self.process.now(host)

    def open_host(self, host: str, parameters: bool = True, complain: Optional[Complain] = None) -> None:
        if any(token[:1].isdigit() for token in host.split("/")):  # before rclpy, which warns as it refuses
            raise DeclarationError(f"ROS 2 refuses the node {host}: a part of a ROS 2 name may not start with a "
                                   "digit; ROS 2 names are letters, digits and _, each part starting with a letter")
        fresh = host not in self.process.hosted  # a name of ours lingers in the graph for a while after shutdown
        if fresh:
            self.refuse_taken_name(host)
        try:
            self.process.host(host, parameters)
        except (ValueError, RCLError, NameValidationException) as error:  # rclpy's name rules (a namespace token
            # may not start with a digit), which are stricter than ROS 1's
            raise DeclarationError(f"ROS 2 refuses the node {host}: {first_line(error)}; ROS 2 names are letters, "
                                   "digits and _, each part starting with a letter") from None
        if fresh and complain is not None:  # a namesake started a moment ago is not in the graph yet
            self.process.watch_name(host, complain)

    def close_host(self, host: str) -> None:
        self.process.close_host(host)

    def closing_hosts(self, hosts: list[str]) -> None:
        self.process.detach(hosts)

    # -- parameters: each belongs to its node --------------------------------------------
    check_param = staticmethod(params.check_param)

    def _owner(self, name: str) -> tuple[Any, str]:
        """The ROS 2 node a parameter ``/ns/node/key`` belongs to, and its key there."""
        for fullname in sorted(self.process.hosts(), key=len, reverse=True):
            if name.startswith(fullname + "/"):
                return self.process.host(fullname), name[len(fullname) + 1:].replace("/", ".")
        raise DeclarationError(f"parameter {name}: on ROS 2 a parameter belongs to a node; set it as that "
                               "node's own, nd.params['key'] = value, while it runs")

    def get_param(self, name: str) -> Any:
        node, key = self._owner(name)
        return node.get_parameter(key).value

    def set_param(self, name: str, value: Any) -> None:
        from rcl_interfaces.msg import ParameterDescriptor
        from rclpy.parameter import Parameter

        params.check_param(name, value)
        node, key = self._owner(name)
        node.serve_parameters()  # reachable from outside (ros2 param, on_param) from its first parameter on
        if node.has_parameter(key):
            node.set_parameters([Parameter(key, value=list(value) if isinstance(value, tuple) else value)])
        else:  # any type later, as nd.params allows on ROS 1
            node.declare_parameter(key, value, ParameterDescriptor(dynamic_typing=True))

    def has_param(self, name: str) -> bool:
        try:
            node, key = self._owner(name)
        except DeclarationError:
            return False
        return node.has_parameter(key)

    def delete_param(self, name: str) -> None:
        node, key = self._owner(name)
        node.undeclare_parameter(key)

    def param_ranges(self, namespace: str) -> dict[str, str]:
        """Nothing for the table: a ROS 2 parameter's range is in its descriptor (``%param NAME --describe``)."""
        return {}

    def build_messages(self, package_dir: Any, into: Any, progress: Progress = no_progress) -> list[str]:
        from .msggen import build_messages

        return build_messages(package_dir, into, progress)

    def build_types_of(self, node: str, wanted: dict[str, str], progress: Progress = no_progress) -> list[str]:
        """Build the types ``wanted`` (type → a topic it is used on) from the running ``node``'s descriptions."""
        from .msggen import build_from_node

        return build_from_node(self.process, node, wanted, progress=progress)

    def watch_param(self, name: str, tell: Callable[[Any], None]) -> params.ParamWatch:
        node, key = self._owner(name)
        return params.ParamWatch(node, key, tell)

    def forget_params(self, names: list[str]) -> None:
        """Nothing to delete: a ROS 2 node's parameters end with it."""

    def refuse_taken_name(self, name: str) -> None:
        """Refuse a node name that a node elsewhere in the graph has.

        ROS 2 lets two nodes share a name and only warns, but tools then mix them up
        (parameters, ``ros2 node info``); as on ROS 1, the name is refused. What the graph
        has not discovered yet (a node started this very moment) cannot be seen.
        """
        namespace, base = name.rsplit("/", 1)
        if (base, namespace or "/") in self._graph().get_node_names_and_namespaces():
            raise NodeStateError(f"a node named {name} is already running in the ROS 2 graph (ROS_DOMAIN_ID "
                                 f"{runtime.domain_id()}); give this node another name")

    # -- the graph, for %topics and completion ----------------------------------------------
    def graph_snapshot(self, timeout: float = 1.0) -> GraphSnapshot:
        """What discovery has found so far (:func:`.graph.snapshot`): read locally, no round trip (but, just
        after rclpy started, once discovery has had its moment: :meth:`ProcessNode.discovered`)."""
        reader = self._graph()
        self.process.discovered(within=timeout)
        return graph.snapshot(reader)

    def where(self) -> str:
        return f"ROS_DOMAIN_ID {runtime.domain_id()}"

    def live_types(self, topics: list[str]) -> dict[str, tuple[str, bool]]:
        """Nothing is refused at the declaration on ROS 2: DDS keeps a type per endpoint and matches none of
        another type, which the type watch tells of (:meth:`ProcessNode.watch_types <.runtime.ProcessNode>`)."""
        return {}

    # -- basenodes, packages, launch files, bags, exports -------------------------------------
    def basenode(self, base: BaseModel, *, log_path: Any = None, on_exit: Any = None) -> BaseProcess:
        """The process of the basenode ``base``: found as ``ros2 run`` finds it, its rules after ``--ros-args``."""
        if self.process.sim_time and base.bag is None and "use_sim_time" not in base.params:
            base = dataclasses.replace(base, params={**base.params, "use_sim_time": True})  # a bag's time runs
        return BaseProcess(nodes.command(base), node_name=base.node_name, log_path=log_path, on_exit=on_exit,
                           env=base.env, control=base.bag is not None)

    own_node_name = staticmethod(nodes.own_node_name)

    def note_link(self, base: BaseModel, process: BaseProcess) -> Optional[str]:
        """Nothing to say: an ament prefix's executables are links (the demo's are) or installed files."""
        return None

    def read_launch(self, launch: Any, node: str, args: Optional[dict[str, Any]]) -> tuple[BaseModel, list[str]]:
        return launchfile.read_base(launch, node, args)

    def launch_base(self, base: BaseModel, process: BaseProcess, node: str, on_rest_exit: Any) -> Any:
        return LaunchBase(base, process, node=node, on_rest_exit=on_rest_exit)

    list_packages = staticmethod(nodes.list_packages)
    list_executables = staticmethod(nodes.list_executables)

    def bags(self) -> Any:
        return bagfile

    def export_flavour(self) -> Any:
        return RclpyScript

    def _graph(self) -> Any:
        """The hidden node that reads the graph; rclpy is started for it if no node has started it yet."""
        if not self.process.started:
            self.process.start(f"/_ipyros_graph_{os.getpid()}")
        return self.process.graph()

    def topic_endpoints(self, topic: str) -> list[tuple[str, str, str, str]]:
        """Who publishes and subscribes to ``topic``, each with its type and the QoS it offers or asks for:
        ``(node, "publisher" | "subscription", "std_msgs/String", "reliable transient-local depth 1")``."""
        reader = self._graph()
        found = []
        for kind, infos in (("publisher", reader.get_publishers_info_by_topic(topic)),
                            ("subscription", reader.get_subscriptions_info_by_topic(topic))):
            for info in infos:
                if not info.node_name.startswith("_"):
                    found.append((f"{info.node_namespace.rstrip('/')}/{info.node_name}", kind,
                                  msgtypes.short_name(info.topic_type), qosmatch.qos_text(info.qos_profile)))
        return sorted(found)

    # -- the graph's services, parameters and nodes, for %services, %call, %params, %nodes ----
    def service_type(self, name: str) -> str:
        self._graph()
        return introspect.service_type(self.process, name)

    def call(self, name: str, cls: type, request: Any, timeout: float) -> Any:
        self._graph()
        return introspect.call(self.process, name, cls, request, timeout)

    def params_under(self, namespace: str) -> dict[str, Any]:
        """Every parameter of the live nodes under ``namespace``, by global name ``/ns/node/key``."""
        prefix = namespace.rstrip("/") + "/"
        found = {}
        snapshot = self.graph_snapshot()
        for node in snapshot.nodes:
            if f"{node}/list_parameters" not in snapshot.services:  # a node without parameters serves none
                continue
            if node.startswith(prefix) or prefix.startswith(node + "/"):
                try:
                    params = introspect.node_params(self.process, node, timeout=1.0)
                except IpyrosError:  # no parameter services (or it just left): said in its row
                    found[f"{node}/*"] = "? (its parameter services do not answer)"
                    continue
                for key, value in params.items():
                    name = f"{node}/{key}"
                    if name.startswith(prefix) or name == namespace.rstrip("/"):
                        found[name] = value
        return dict(sorted(found.items()))

    def read_param(self, name: str) -> Any:
        """The parameter ``/ns/node/key`` of any live node (``%param``)."""
        node, key = self._live_owner(name)
        values = introspect.node_params(self.process, node)
        if key not in values:
            raise DeclarationError(f"{node} has no parameter {key!r}; it has: {', '.join(values) or 'none'}")
        return values[key]

    @staticmethod
    def size_note(size: float) -> Optional[str]:
        return fastdds.size_note(size)

    #: Parameters every rclpy node has, which %params leaves out unless asked.
    standard_params: tuple[str, ...] = ("use_sim_time", "start_type_description_service")

    def write_param(self, name: str, value: Any) -> Any:
        """Set the parameter ``/ns/node/key`` of any live node (``%param NAME VALUE``); the value set.

        An integer given for a double parameter is made a double (as ROS 1 would store it): ROS 2
        refuses to change a parameter's type, and ``3`` typed at the prompt means ``3.0`` there.
        """
        node, key = self._live_owner(name)
        current = introspect.node_params(self.process, node).get(key)
        if isinstance(current, float) and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        params.check_param(name, value)
        if node in self.process.hosts():
            self.set_param(name, value)
        else:
            introspect.set_node_param(self.process, node, key, value)
        return value

    def describe_param(self, name: str) -> dict[str, Any]:
        """The parameter ``/ns/node/key``'s type, description, range (``ros2 param describe``)."""
        node, key = self._live_owner(name)
        return introspect.describe_node_param(self.process, node, key)

    def _live_owner(self, name: str) -> tuple[str, str]:
        for node in sorted(self.graph_snapshot().nodes, key=len, reverse=True):
            if name.startswith(node + "/"):
                return node, name[len(node) + 1:].replace("/", ".")
        raise DeclarationError(f"parameter {name}: no live node owns it (on ROS 2 a parameter is /node/key); "
                               "%nodes lists the nodes")

    def node_pid(self, node: str) -> Optional[int]:
        return None  # ROS 2 discovery does not say

    def lifecycle(self, node: str, transition: Optional[str] = None) -> tuple[str, list[str]]:
        """A lifecycle node's state and the transitions it offers, after ``transition`` if given (``%lifecycle``)."""
        self._graph()
        return introspect.lifecycle(self.process, node, transition)

    def node_connections(self, node: str) -> list[tuple[str, str, str, str]]:
        return []  # DDS matches endpoints, and the graph does not list who is matched with whom

    def ping_node(self, node: str) -> float:
        """How long ``node`` takes to answer a call of one of its services, in ms (ROS 2 has no node ping)."""
        started = time.perf_counter()
        introspect.ping(self.process, node, timeout=2.0)
        return (time.perf_counter() - started) * 1e3

    def kill_node(self, node: str) -> None:
        raise IpyrosError(f"ROS 2 has no way to ask {node} to end (ros2 node has no kill); stop its process, or "
                          "for a lifecycle node use its shutdown transition")

    def cleanup_nodes(self) -> list[str]:
        return []  # discovery forgets a node that is gone by itself: nothing is left registered

    def describe(self) -> str:
        """One line for ``%load_ext``: which ROS 2, which domain, which middleware, how far discovery reaches."""
        return describe(self.transport)

    def __repr__(self) -> str:
        return f"<ipyros backend {self.name}>"


_DISTROS = {3: "Humble", 7: "Jazzy", 9: "Kilted"}  # rclpy's major version in each distro


def describe(transport: str = "") -> str:
    from importlib.metadata import PackageNotFoundError, version

    import rclpy

    try:
        release = version("rclpy")
    except PackageNotFoundError:
        release = "?"
    distro = os.environ.get("ROS_DISTRO") or _DISTROS.get(int(release.split(".")[0]) if release[:1].isdigit() else -1)
    reach = fastdds.discovery_range()
    return (f"ROS 2{f' {distro.capitalize()}' if distro else ''} (rclpy {release}), ROS_DOMAIN_ID "
            f"{runtime.domain_id()}, {rclpy.get_rmw_implementation_identifier()}, discovery "
            f"{reach.lower()}{f', {transport}' if transport else ''}; the DSL, wrapping, %topics, %echo, %pub, "
            "%demo and completion run here")
