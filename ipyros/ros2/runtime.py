"""rclpy in the session's process: one context, one executor, a ROS 2 node for each DSL node.

Unlike rospy, rclpy lets a process hold many nodes: each DSL node is a ROS 2 node of its
own (``ros2 node list`` shows each by its name), all in one context, their callbacks
run by one executor on a thread of its own, so that the prompt stays free. Signals stay
IPython's: Ctrl-C interrupts the prompt, not the nodes.

The executor is rclpy's single-threaded one, as ``rclpy.spin`` uses: its multi-threaded
executor, which would let one blocking handler leave the others running, cannot keep up
with a 1 kHz topic on two cores (one second behind and losing messages in
``bench/relay_ros2.py``), and the C++ events executor cannot take a node added while it
spins, which a prompt does all the time. A handler that blocks is kept from holding the
session's other callbacks by :mod:`ipyros.ros2.spinning`: its lane moves to a thread of its
own within about a tenth of a second, and a new thread spins the executor.

The nodes' endpoints are in :mod:`ipyros.ros2.endpoints`; QoS in rclpy's terms :mod:`ipyros.ros2.qosmatch`; a
node's interface as discovery sees it :mod:`ipyros.ros2.graph`; parameters :mod:`ipyros.ros2.params`.
"""

from __future__ import annotations

import os
import threading
import time
from typing import Any, Callable, Optional

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from ..core import msgtypes
from ..core.errors import NodeStateError
from .qosmatch import Complain, peer_name
from .spinning import HostNode, Spinner

__all__ = ["ProcessNode", "domain_id"]


def domain_id() -> str:
    """The DDS domain this process talks in (what names a ROS 2 "graph")."""
    return os.environ.get("ROS_DOMAIN_ID") or "0"


class ProcessNode:
    """rclpy in this process: one context, one executor thread, one ROS 2 node per DSL node."""

    #: Whether the session's DSL nodes share one ROS node, which the graph shows: no, each is a node of its own.
    shared = False

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.name: Optional[str] = None  # the first node's name, for messages (there is no one process node)
        self._context: Any = None
        self._executor: Any = None
        self.spinner: Optional[Spinner] = None
        self._started_at = 0.0  # when rclpy started: discovery needs a moment after it
        self._hosts: dict[str, Node] = {}
        self.hosted: set[str] = set()  # every name this process has had a node at (the graph lags behind)
        self._watchers: list[Callable[[], None]] = []  # bound methods: their __self__._node is the node they are of
        #: Publications that take the QoS of a topic's publishers ({topic: [Publication]}: the endpoints' own, see
        #: :class:`~ipyros.ros2.endpoints.Publication`; the process only keeps them).
        self.followers: dict[str, list[Any]] = {}
        self._watch_timer: Any = None
        self._looks = 0
        self._typed: list[tuple[str, str, Complain]] = []  # (topic, type, complain): peers of another type are told
        self._told: set[tuple[str, str, str, Complain]] = set()
        #: New nodes whose name is watched for a namesake: {fullname: (complain, until)}; one look for them all.
        self._named: dict[str, tuple[Complain, float]] = {}
        self._caller: Optional[tuple[Node, Any, Spinner]] = None
        #: Whether the session's nodes run on /clock (a bag's time): each node's use_sim_time, new ones too.
        self.sim_time = False

    @property
    def started(self) -> bool:
        return self.name is not None

    def start(self, name: str, master_uri: Optional[str] = None) -> str:
        """Initialise rclpy and start the executor thread (once); ``master_uri`` is ROS 1's and unused."""
        with self._lock:
            if self.name is not None:
                return self.name
            from rclpy.signals import SignalHandlerOptions

            context = rclpy.Context()
            rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
            executor = SingleThreadedExecutor(context=context)  # why: the module's docstring
            self.spinner = Spinner(executor, "ipyros-rclpy")
            self.spinner.start()
            self._context, self._executor, self.name = context, executor, name
            self._started_at = time.monotonic()
            return name

    #: How long a new participant takes to hear from its peers on this host (s): discovery
    #: announces itself at start and peers answer at once, well within this even on a loaded machine.
    DISCOVERY_SETTLE = 1.0

    def discovered(self, within: float) -> None:
        """Return once discovery has had its time to find the peers already running (at most ``within`` s).

        A graph read right after rclpy starts knows no peer yet: ``%pub`` would see no subscriber
        to wait for and send into the void. Later reads return at once.
        """
        left = self._started_at + self.DISCOVERY_SETTLE - time.monotonic()
        if left > 0:
            time.sleep(min(left, within))

    def host(self, fullname: str, parameters: bool = True) -> Node:
        """The ROS 2 node of the DSL node ``fullname`` (``/ns/name``), made on first use.

        ``parameters=False``: without the parameter services (six entities fewer for the
        executor to wait on, for a node that has no parameters; :meth:`HostNode.serve_parameters`
        starts them when it gets one).
        """
        with self._lock:
            if self.name is None:
                raise NodeStateError("the ROS 2 nodes are not running; call create() on a node first")
            node = self._hosts.get(fullname)
            if node is None:
                namespace, base = fullname.rsplit("/", 1)
                node = HostNode(base, namespace=namespace or "/", context=self._context,
                                start_parameter_services=parameters)
                self._executor.add_node(node)
                self._hosts[fullname] = node
                self.hosted.add(fullname)
                if self.sim_time:
                    _use_sim_time(node, True)
            return node

    #: How long a new node's name is watched for a namesake that discovery had not shown yet (s).
    NAME_SETTLE = 3.0

    def watch_name(self, fullname: str, complain: Complain, seconds: float = NAME_SETTLE) -> None:
        """Tell ``complain`` once if, within ``seconds`` of this node's start, the graph shows a second node named
        ``fullname``: another process started one a moment before, which discovery had not shown when the name
        was checked (ROS 2 lets two nodes share a name; tools then mix them up)."""
        with self._lock:
            first = not self._named
            self._named[fullname] = (complain, time.monotonic() + seconds)
        if first:
            self.watch(self._look_for_namesakes)

    def _look_for_namesakes(self) -> None:
        """One read of the graph's node names for every name watched (a session that creates 100 nodes at once
        asks once a look, not 100 times)."""
        with self._lock:
            named = dict(self._named)
        now, names = time.monotonic(), self.caller().get_node_names_and_namespaces()
        for fullname, (complain, until) in named.items():
            namespace, base = fullname.rsplit("/", 1)
            twice = names.count((base, namespace or "/")) > 1
            if twice or now > until:
                with self._lock:
                    self._named.pop(fullname, None)
            if twice:
                complain(f"a second node named {fullname} showed up in the ROS 2 graph (ROS_DOMAIN_ID {domain_id()}) "
                         "as this one started: two nodes now share the name, and tools mix them up (parameters, "
                         "ros2 node info); shut this one down and create it under another name")
        with self._lock:
            if not self._named:
                self._watchers = [w for w in self._watchers if w != self._look_for_namesakes]

    def use_sim_time(self, on: bool) -> None:
        """Run every node of the session on /clock (``on``: its timers and its now()), or on the system clock."""
        with self._lock:
            self.sim_time = on
            for node in self._hosts.values():
                _use_sim_time(node, on)

    def now(self, fullname: str) -> float:
        """The ROS time (s) of the DSL node ``fullname``'s clock: a bag's time while the session runs on /clock."""
        node = self._hosts.get(fullname)
        if node is None:
            raise NodeStateError(f"{fullname} is not running; call create() first")
        return node.get_clock().now().nanoseconds / 1e9

    def caller(self) -> Node:
        """A hidden node, spun by an executor of its own, for what must not run on the main one.

        A callback that waits for a service's answer on the one executor thread would wait
        forever (the answer is a callback too): service relays make their calls from here.
        The graph watch of the relays runs here too.
        """
        with self._lock:
            if self.name is None:
                raise NodeStateError("the ROS 2 nodes are not running; call create() on a node first")
            if self._caller is None:
                node = Node(f"_ipyros_caller_{os.getpid()}", context=self._context, start_parameter_services=False)
                executor = SingleThreadedExecutor(context=self._context)
                executor.add_node(node)
                spinner = Spinner(executor, "ipyros-rclpy-calls", watch=False)  # it runs no handler
                spinner.start()
                self._caller = (node, executor, spinner)
            return self._caller[0]

    def graph(self) -> Node:
        """A hidden node of ipyros's own that reads the ROS 2 graph (it hosts no endpoint of yours)."""
        return self.host(f"/_ipyros_graph_{os.getpid()}", parameters=False)

    #: How often the graph watch looks (s): a basenode's publisher is followed within this.
    WATCH_PERIOD = 0.1

    def watch(self, follow: Callable[[], None]) -> None:
        """Call ``follow()`` on every look of the one graph watch, until :meth:`unwatch`.

        One timer serves every relay, instead of one timer each; it runs on the caller
        node's executor, so that looking at the graph never delays a message on the
        executor that carries them.
        """
        caller = self.caller()
        with self._lock:
            self._watchers.append(follow)
            if self._watch_timer is None:
                self._watch_timer = caller.create_timer(self.WATCH_PERIOD, self._look)

    def unwatch(self, follow: Callable[[], None]) -> None:
        with self._lock:
            if follow in self._watchers:
                self._watchers.remove(follow)

    def _look(self) -> None:
        with self._lock:
            watchers = list(self._watchers)
            self._looks += 1
            types_due = self._looks % self.TYPES_EVERY == 0 and self._typed
        for follow in watchers:
            follow()
        if types_due:
            self._check_types()

    #: Looks between two checks of the types peers publish (about once a second).
    TYPES_EVERY = 10

    def watch_types(self, topic: str, type_name: str, complain: Optional[Complain]) -> None:
        """Tell ``complain`` once per peer that publishes ``topic`` as another type than ``type_name``.

        DDS matches nothing between two types and says nothing about it: a subscription just
        never hears the peer. The graph knows each publisher's type, so it is looked at.
        """
        if complain is None:
            return
        self.caller()  # the watch runs on the caller node's executor
        with self._lock:
            self._typed.append((topic, type_name, complain))
            if self._watch_timer is None:
                self._watch_timer = self._caller[0].create_timer(self.WATCH_PERIOD, self._look)

    def unwatch_types(self, complain: Optional[Complain], topic: str) -> None:
        with self._lock:
            self._typed = [t for t in self._typed if not (t[0] == topic and t[2] is complain)]

    def _check_types(self) -> None:
        with self._lock:
            typed = list(self._typed)
        graph, publishers = self.caller(), {}
        for topic, type_name, complain in typed:
            if topic not in publishers:
                publishers[topic] = graph.get_publishers_info_by_topic(topic)
            for info in publishers[topic]:
                theirs, peer = msgtypes.short_name(info.topic_type), peer_name(info.node_namespace, info.node_name)
                if theirs == type_name or peer is None or (topic, peer, theirs, complain) in self._told:
                    continue  # (a peer discovery has not named yet is looked at again next time)
                self._told.add((topic, peer, theirs, complain))
                complain(msgtypes.another_type_line(topic, peer, theirs, type_name, "ROS 2"))

    def hosts(self) -> list[str]:
        """The full names of the DSL nodes that have a ROS 2 node now."""
        with self._lock:
            return list(self._hosts)

    def detach(self, fullnames: list[str]) -> None:
        """Take these nodes off the executor at once, before they close: each endpoint destroyed while its node is on
        it makes the executor build its wait set again from every entity of the session (thousands with 150 nodes:
        shutting them down one by one took 25 s)."""
        with self._lock:
            nodes = [self._hosts[name] for name in fullnames if name in self._hosts]
            # nor does the graph watch look for their endpoints any more (it would hold the graph meanwhile)
            self._watchers = [w for w in self._watchers if getattr(w.__self__, "_node", None) not in nodes]
            for name in fullnames:
                self._named.pop(name, None)
        for node in nodes:
            self._executor.remove_node(node)

    def close_host(self, fullname: str) -> None:
        with self._lock:
            node = self._hosts.pop(fullname, None)
            if node is not None:
                self._executor.remove_node(node)
                node.destroy_node()

    def register_again(self) -> tuple[int, int, int]:
        """Nothing to do: ROS 2 has no master to forget what was declared."""
        return 0, 0, 0

    def shutdown(self, reason: str = "ipyros exit") -> None:
        with self._lock:
            if self.name is None:
                return
            for node in self._hosts.values():
                self._executor.remove_node(node)
                node.destroy_node()
            self._hosts.clear()
            self._watchers.clear()
            self._watch_timer = None
            spinners = [self.spinner]
            if self._caller is not None:
                node, executor, spinner = self._caller
                executor.remove_node(node)
                node.destroy_node()
                executor.shutdown(timeout_sec=2.0)
                spinners.append(spinner)
                self._caller = None
            self._executor.shutdown(timeout_sec=2.0)
            rclpy.try_shutdown(context=self._context)
            for spinner in spinners:  # a spinning thread left at exit aborts the interpreter
                if spinner is not None:
                    spinner.stop(timeout=5.0)
            self.name = None


def _use_sim_time(node: Node, on: bool) -> None:
    from rclpy.parameter import Parameter

    node.set_parameters([Parameter("use_sim_time", Parameter.Type.BOOL, on)])
