"""The backend seam: what the rest of ipyros asks of a ROS, so that nothing outside ``ros1/`` and ``ros2/`` knows
which ROS runs.

The DSL, the node model, the plan, keeping the work, the tools and the magics are the same
on ROS 1 and ROS 2; a :class:`Backend` is what runs them on one ROS. A session holds
exactly one, chosen when it starts (:func:`choose`). Each endpoint it makes has
``close()``; publications and relays also ``figures()``
(:class:`~ipyros.core.slots.SendFigures`), and publications ``write(msg)``. ``host`` is
the full name of the DSL node an endpoint belongs to: on ROS 2 each DSL node is a ROS node
of its own, on ROS 1 they share the process's.

=======================  =================================================================
what is asked            what the backend gives
=======================  =================================================================
the session's ROS        ``process`` (its node(s): ``name``, ``started``); ``start(name,
                         session)`` (ROS 1: the master found or started, watched);
                         ``require_graph(doing)`` (fails in a moment if the master is
                         gone); ``connect(session)`` (the load line); ``closing()`` and
                         ``close()`` at the end; ``check_config(session, master_uri)``
publish / write          ``publication(host, topic, cls, qos, complain, follows, gate)``: the gate
                         of a guard every message passes first (relays take one too)
subscribe(h)             ``subscription(host, topic, cls, slot, qos, complain)``: the slot
                         calls the handler; ``complain(text)`` tells the session of what
                         goes wrong after it opened (a QoS mismatch, a peer of another type)
reuse relay              ``relay(host, source, target, cls, on_wrong_type, complain)``:
                         bytes, not objects, with the QoS of the source's publishers
timer                    ``timer(host, period, slot, oneshot, complain)``
service / reuse          ``service(host, name, cls, slot)``,
                         ``service_relay(host, source, target, cls, complain)``
actions (new / reuse)    ``action_server(host, name, cls, slot, forward)``: each goal to the
                         slot on a thread of its own (``forward``: the basenode's server);
                         ``action_relay(host, source, target, cls, on_wrong_type, complain)``:
                         all of an action's parts as one unit; ``action_parts``: the
                         suffixes a basenode's action is remapped by; ``send_goal(name, cls,
                         goal, feedback, timeout)``: a :class:`~ipyros.core.actions.SentGoal`;
                         ``watch_action(name, cls, tell)``: the goals others send, as events
a bag's time             ``bag_time(on)``: the session on a bag player's /clock (what applies,
                         one line); ``now(host)``: a DSL node's ROS time
a DSL node's life        ``open_host(host)`` at create(), ``close_host(host)`` at shutdown();
                         ``closing_hosts(hosts)``: several shut down together next
its params               ``check_param``, ``get_param``, ``set_param``, ``has_param``,
                         ``delete_param`` (by global name); ``forget_params(names)``: what
                         ended nodes left on a parameter server (ROS 1)
a free node name         ``refuse_taken_name(name)``
the graph                ``graph_snapshot(timeout)`` (a :class:`~ipyros.core.graph.GraphSnapshot`),
                         ``where()`` (its name for titles), ``live_types(topics)`` (the type
                         each has, and whether only this session uses it), ``check_graph()``
a basenode               ``basenode(base, log_path, on_exit)``: its process (lookup and
                         command line as rosrun / ros2 run); ``wait_for_node(name, timeout,
                         alive, settle)``: its :class:`~ipyros.core.records.Interface` once
                         settled; ``launch_base(...)`` and ``read_launch(...)``: a node of
                         a launch file (``launch_params_on_server``: who sets its params);
                         ``note_link(base, process)``
packages                 ``list_packages()``, ``list_executables(package)``
message types            ``build_messages(package_dir, into, progress)``: a workspace's package
                         made importable; ``build_types_of(node, wanted, progress)``: the types
                         a running node uses and this Python lacks, from the node itself (ROS 2);
                         ``relays_any_type`` / ``raw_relay(...)``: bytes of any type (ROS 1)
bags                     ``bags()``: reading, playing and writing bags of this ROS
exports                  ``export_flavour()``: how a node is written as a script of this ROS
%services, %call         ``service_type(name)``, ``call(name, cls, request, timeout)``
%params, %param          ``params_under(namespace)``, ``read_param(name)``,
                         ``write_param(name, value)``: any node's (the value set: ROS 2
                         makes an int a double for a double parameter); ``standard_params``
%topics -v               ``topic_endpoints(topic)``: each endpoint with its type and QoS
%bw                      ``size_note(size)``: one line when messages of that size are slow or
                         lost with the transport's defaults (ROS 2's Fast DDS), else None
%node                    ``node_pid(name)``: None where the ROS does not say (ROS 2);
                         ``ping_node``, ``kill_node``, ``cleanup_nodes`` (``%nodes --cleanup``)
=======================  =================================================================
"""

from __future__ import annotations

import importlib.util
import os
from typing import Any, Callable, Optional, Protocol

from ..core.errors import IpyrosError
from ..core.graph import GraphSnapshot
from ..core.model import BaseModel
from ..core.names import NameRules
from ..core.progress import Progress, no_progress
from ..core.qos import Qos
from ..core.records import Interface
from ..core.sessionlink import SessionLink
from ..core.slots import HandlerSlot

#: Told, in one line, what went wrong with an endpoint after it opened (a QoS mismatch, ...).
Complain = Callable[[str], None]

__all__ = ["Backend", "Complain", "choose"]


class Backend(Protocol):
    """One ROS, as the rest of ipyros sees it (see the module's table)."""

    name: str  # "ROS 1", "ROS 2"
    name_rules: NameRules  # what its graph names may be beyond the shared rules
    process: Any
    qos_fields: tuple[str, ...]  # the QoS fields that mean something here (ROS 1: durability)

    # the session's ROS
    def start(self, name: str, session: SessionLink) -> str: ...
    def connect(self, session: SessionLink, wait: bool = True) -> str: ...
    def require_graph(self, doing: str) -> None: ...
    def check_config(self, session: SessionLink, master_uri: Optional[str]) -> None: ...
    def closing(self) -> None: ...
    def close(self) -> None: ...
    def describe(self) -> str: ...

    # endpoints
    def publication(self, host: str, topic: str, cls: type, qos: Qos, complain: Complain,
                    follows: Optional[str] = None, gate: Any = None) -> Any: ...
    def subscription(self, host: str, topic: str, cls: type, slot: HandlerSlot, qos: Qos,
                     complain: Complain) -> Any: ...
    def relay(self, host: str, source: str, target: str, cls: type,
              on_wrong_type: Optional[Callable[[str], None]], complain: Complain, gate: Any = None) -> Any: ...
    relays_any_type: bool  # whether raw_relay works: a type this Python cannot import relayed as bytes
    def raw_relay(self, host: str, source: str, target: str, type_name: str,
                  on_wrong_type: Optional[Callable[[str], None]], complain: Complain) -> Any: ...
    def timer(self, host: str, period: float, slot: HandlerSlot, oneshot: bool,
              complain: Optional[Complain] = None) -> Any: ...
    def service(self, host: str, name: str, cls: type, slot: HandlerSlot) -> Any: ...
    def service_relay(self, host: str, source: str, target: str, cls: type, complain: Complain) -> Any: ...
    action_parts: tuple[str, ...]
    def action_server(self, host: str, name: str, cls: type, slot: HandlerSlot, forward: Optional[str]) -> Any: ...
    def action_relay(self, host: str, source: str, target: str, cls: type,
                     on_wrong_type: Optional[Callable[[str], None]], complain: Complain) -> Any: ...
    def send_goal(self, name: str, cls: type, goal: Any, feedback: Optional[Callable[[Any], None]],
                  timeout: float) -> Any: ...
    def watch_action(self, name: str, cls: type, tell: Callable[[str, str, Any], None]) -> Any: ...
    def serialize(self, msg: Any) -> bytes: ...  # a message as its ROS sends it (a guard's stop message)
    def sentinel_command(self) -> list[str]: ...  # how a guard's own process is run (argv, before its two fds)
    def bag_time(self, on: bool) -> str: ...  # run on a bag player's /clock (or not); what applies, one line
    def now(self, host: str) -> float: ...  # a DSL node's ROS time (s): a bag's while its clock runs
    # parameters: it has some now; complain: told of a namesake that shows up as it starts (ROS 2)
    def open_host(self, host: str, parameters: bool = True, complain: Optional[Complain] = None) -> None: ...
    def close_host(self, host: str) -> None: ...
    def closing_hosts(self, hosts: list[str]) -> None: ...  # these are shut down next: stop their callbacks at once

    # params of the session's nodes, by global name
    def check_param(self, name: str, value: Any) -> None: ...
    def get_param(self, name: str) -> Any: ...
    def set_param(self, name: str, value: Any) -> None: ...
    def has_param(self, name: str) -> bool: ...
    def delete_param(self, name: str) -> None: ...
    def forget_params(self, names: list[str]) -> None: ...
    def watch_param(self, name: str, tell: Callable[[Any], None]) -> Any: ...  # tell(value) on each set; close()
    def build_messages(self, package_dir: Any, into: Any, progress: Progress = no_progress) -> list[str]: ...
    def build_types_of(self, node: str, wanted: dict[str, str], progress: Progress = no_progress) -> list[str]: ...
    def refuse_taken_name(self, name: str) -> None: ...

    # the graph
    def graph_snapshot(self, timeout: float = 1.0) -> GraphSnapshot: ...
    def where(self) -> str: ...
    def live_types(self, topics: list[str]) -> dict[str, tuple[str, bool]]: ...
    def check_graph(self) -> None: ...

    # basenodes, packages, launch files, bags, exports
    def basenode(self, base: BaseModel, *, log_path: Any = None, on_exit: Any = None) -> Any: ...
    def note_link(self, base: BaseModel, process: Any) -> Optional[str]: ...
    def own_node_name(self, base: BaseModel) -> Optional[str]: ...  # from its Python source, never run
    def wait_for_node(self, name: str, timeout: float = 10.0, alive: Optional[Callable[[], bool]] = None,
                      settle: float = 0.5) -> Interface: ...
    def read_launch(self, launch: Any, node: str, args: Optional[dict[str, Any]]) -> tuple[BaseModel, list[str]]: ...
    launch_params_on_server: bool  # a launch file's params: set by launch_base's handle (ROS 1), else on the command line
    def launch_base(self, base: BaseModel, process: Any, node: str, on_rest_exit: Any) -> Any: ...
    def list_packages(self) -> list[str]: ...
    def list_executables(self, package: str) -> list[str]: ...
    def bags(self) -> Any: ...
    def export_flavour(self) -> Any: ...

    # any node's services, params and endpoints (the introspection magics)
    def service_type(self, name: str) -> str: ...
    def call(self, name: str, cls: type, request: Any, timeout: float) -> Any: ...
    def params_under(self, namespace: str) -> dict[str, Any]: ...
    def read_param(self, name: str) -> Any: ...
    def write_param(self, name: str, value: Any) -> Any: ...  # the value set (coerced to the param's type)
    standard_params: tuple[str, ...]  # parameters every node has (%params leaves them out)
    def describe_param(self, name: str) -> dict[str, Any]: ...
    def param_ranges(self, namespace: str) -> dict[str, str]: ...  # ROS 1: dynamic_reconfigure's, for %params  # its type (ROS 2: description, range)
    def topic_endpoints(self, topic: str) -> list[tuple[str, str, str, str]]: ...
    def size_note(self, size: float) -> Optional[str]: ...  # %bw: a word on messages this large (ROS 2)
    def node_pid(self, node: str) -> Optional[int]: ...
    def ping_node(self, node: str) -> float: ...  # ms to answer (ROS 1: XML-RPC; ROS 2: a parameter call)
    def lifecycle(self, node: str, transition: Optional[str] = None) -> tuple[str, list[str]]: ...  # ROS 2
    def node_connections(self, node: str) -> list[tuple[str, str, str, str]]: ...  # (topic, in/out, peer, transport)
    def kill_node(self, node: str) -> None: ...  # ask it to end (ROS 1); ROS 2 refuses in one line
    def cleanup_nodes(self) -> list[str]: ...  # forget dead registrations (ROS 1); the names


def choose() -> Backend:
    """The backend of a new session: ``IPYROS_ROS`` (``1`` or ``2``) if set, else ``ROS_VERSION``
    (what a sourced ROS install sets), else ROS 1 if rospy is importable, else ROS 2.

    The two backends are imported here, when the session chooses: the node layer knows
    the seam, not which ROS answers it.
    """
    wanted = os.environ.get("IPYROS_ROS") or os.environ.get("ROS_VERSION") or ""
    if wanted not in ("", "1", "2"):
        raise IpyrosError(f"IPYROS_ROS={wanted!r}: give 1 (ROS 1, rospy) or 2 (ROS 2, rclpy)")
    if not wanted:
        wanted = "1" if importlib.util.find_spec("rospy") is not None else "2"
    try:
        if wanted == "2":
            from ..ros2.backend import Ros2  # noqa: PLC0415 - chosen at run time (see the docstring)

            return Ros2()
        from ..ros1.backend import Ros1  # noqa: PLC0415 - chosen at run time (see the docstring)

        return Ros1()
    except ImportError as error:
        which = "ROS 2 (rclpy: pip install 'ros-rclpy[fastrtps]')" if wanted == "2" else "ROS 1 (rospy)"
        raise IpyrosError(f"ipyros was asked for {which}, which this Python cannot import ({error}); "
                          "install it, or set IPYROS_ROS to the ROS you have") from None
