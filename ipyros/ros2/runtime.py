"""rclpy: the session's ROS 2 nodes and their endpoints.

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

Endpoints mirror :mod:`ipyros.ros1.runtime`: each has ``close()``; handlers go through
a :class:`~ipyros.core.slots.HandlerSlot`; relays forward serialized bytes (``raw=True``),
deserialising nothing unless a guard stands on the output (it reads the values it checks).
"""

from __future__ import annotations

import functools
import os
import queue
import threading
import time
from typing import Any, Callable, Optional

import rclpy
from rclpy._rclpy_pybind11 import RCLError
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, LivelinessPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message, serialize_message

from ..core import msgtypes, wire
from ..core.errors import BaseNodeError, DeclarationError, HandlerError, MessageTypeError, NodeStateError, cut
from ..core.graph import settled
from ..core.guard import Guarding
from ..core.msgbuild import conform
from ..core.qos import Qos
from ..core.records import Interface
from ..core.slots import Arrival, HandlerSlot, Pristine, SendFigures
from .spinning import HostNode, Lane, Spinner

#: Reliable, and deep enough that a burst is not cut short: what ROS 1's unbounded
#: subscriber queue gave. A declaration's ``qos=`` overrides any of it.
_DEPTH = 1000

Complain = Callable[[str], None]


def domain_id() -> str:
    """The DDS domain this process talks in (what names a ROS 2 "graph")."""
    return os.environ.get("ROS_DOMAIN_ID") or "0"


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


def _mismatch_report(node: Node, topic: str, mine: Qos, what: str, complain: Optional[Complain]) -> Any:
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
        #: Publications that take the QoS of a topic's publishers ({topic: [Publication]}; see Publication).
        self.followers: dict[str, list[Publication]] = {}
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


def _made(node: Node, make: Callable[[], Any], patience: float = 2.0) -> Any:
    """``make()``'s publisher or subscription, once the one this session just closed on the topic is gone.

    rclpy destroys an endpoint only when the executor lets go of it (its QoS event handlers are in
    the executor's wait set): until then Fast DDS still holds the topic with the old type, and an
    endpoint of a new type on it is refused ("incompatible type"). A topic retyped live waits for
    that moment: the executor is woken, and the endpoint made again, for ``patience`` seconds at most.
    """
    deadline = time.monotonic() + patience
    while True:
        try:
            return make()
        except Exception as error:  # noqa: BLE001 - rclpy raises a plain RCLError here
            if "incompatible type" not in str(error) or time.monotonic() > deadline:
                raise
        executor = node.executor
        if executor is not None:
            executor.wake()
        time.sleep(0.02)


def _use_sim_time(node: Node, on: bool) -> None:
    from rclpy.parameter import Parameter

    node.set_parameters([Parameter("use_sim_time", Parameter.Type.BOOL, on)])


class Publication:
    """A publisher; ``write`` checks the message, then publishes it.

    One that ``follows`` a topic (an output of a basenode the node took over) takes that topic's
    publishers' QoS, so that a transient-local (latched) map stays latched once intercepted. The
    subscription that hears ``follows`` changes it before it changes itself (:meth:`take`): a
    latched message it then hears, and the handler writes, goes out on the latched publisher.
    """

    def __init__(self, node: Node, topic: str, cls: type, qos: Qos = Qos(),
                 complain: Optional[Complain] = None, process: Optional["ProcessNode"] = None,
                 follows: Optional[str] = None, gate: Optional[Guarding] = None) -> None:
        self.topic, self.cls, self.count = topic, cls, 0
        #: A guard's gate every message passes first (``check(msg)``: what to send, or nothing), or None.
        self.gate = gate
        self._node, self._complain, self.qos = node, complain, qos
        self._lock = threading.Lock()
        self._pub = self._open(qos)
        self._process, self._follows = process, follows
        if process is not None and follows is not None:  # see the class docstring
            process.followers.setdefault(follows, []).append(self)
            found = _publishers_qos(node, follows)
            if found is not None:
                self.take(found)

    def _open(self, qos: Qos) -> Any:
        node, topic = self._node, self.topic
        return _made(node, lambda: node.create_publisher(
            self.cls, topic, profile_of(qos), event_callbacks=_mismatch_report(node, topic, qos, "publication",
                                                                             self._complain)))

    def take(self, source: Qos) -> None:
        """Publish as the followed topic's publishers do (``source``: their QoS), if not already."""
        with self._lock:
            if _effective(source) == _effective(self.qos):  # a new publisher would lose a moment's messages
                return
            old, self.qos = self._pub, source
            self._pub = self._open(source)
            self._node.destroy_publisher(old)

    def write(self, msg: Any) -> None:
        if isinstance(msg, type):
            raise MessageTypeError(f"{self.topic}: write() got the class {msg.__name__}, not a message; "
                                   f"build one, {msg.__name__}(), and write that (nothing was sent)")
        conform(msg)  # rclpy would send an int in a float field as garbage (see msgbuild.conform)
        gate = self.gate
        if gate is not None:
            msg = gate.check(msg).send
            if msg is None:  # dropped by the guard
                return
        try:
            self._pub.publish(msg)
        except (TypeError, ValueError, AssertionError) as error:
            raise MessageTypeError(f"{self.topic}: the message cannot be sent ({error}); nothing was sent") from None
        except RCLError as error:  # the middleware's refusal, e.g. a reliable reader too far behind
            raise NodeStateError(f"{self.topic}: ROS 2 refused the message ({str(error).split(',')[0]}); nothing "
                                 "was sent: a reliable subscriber is behind; send it again") from None
        self.count += 1

    def connections(self) -> int:
        return self._pub.get_subscription_count()

    def figures(self) -> SendFigures:
        return SendFigures(self.topic, "publish", self.count, self.connections(), 0, 0)

    def close(self) -> None:
        if self._process is not None and self._follows is not None:
            self._process.followers.get(self._follows, []).remove(self)
        self._node.destroy_publisher(self._pub)


def _effective(qos: Qos) -> tuple[str, str, Optional[int]]:
    """What a subscriber sees of a publisher's QoS: reliability, durability, and the depth kept when latched."""
    return (qos.reliability or "reliable", qos.durability or "volatile", (qos.depth or 1) if qos.latched else None)


class _Publishers:
    """When the graph watch reads a topic's publishers again: only once their number changed (a count costs a
    fraction of a read of each one's QoS, which builds Python objects; with 150 endpoints watched ten times a
    second the reads kept a core busy), and every :attr:`ALL_SAME_EVERY` looks all the same (a publisher replaced
    by one of another QoS leaves the number as it was)."""

    ALL_SAME_EVERY = 10

    def __init__(self, node: Node, topic: str) -> None:
        self._node, self._topic, self._count, self._looks = node, topic, -1, 0

    def changed(self) -> bool:
        self._looks += 1
        count = self._node.count_publishers(self._topic)
        if count == self._count and self._looks % self.ALL_SAME_EVERY:
            return False
        self._count = count
        return True


def _publishers_qos(node: Node, topic: str) -> Optional[Qos]:
    """The QoS that matches every publisher of ``topic`` now and gets the most from them; None if none.

    Transient-local only if they all are (a transient-local reader matches no volatile
    writer), best-effort if any is (a reliable reader matches no best-effort writer);
    what ``ros2 topic echo`` chooses too.
    """
    found = [qos_of(info.qos_profile) for info in node.get_publishers_info_by_topic(topic)]
    if not found:
        return None
    latched = all(q.latched for q in found)
    return Qos(max(q.depth or 1 for q in found) if latched else None,
               "best_effort" if any(q.reliability == "best_effort" for q in found) else "reliable",
               "transient_local" if latched else "volatile")


class Subscription:
    """A subscription whose callback is a :class:`HandlerSlot`.

    Declared without reliability and durability (``qos=`` left out, or a depth only), it
    takes them from the topic's publishers, now and as they show up (the process's graph
    watch): so a latched topic's last message reaches a subscription made later, as on
    ROS 1, and a best-effort sensor is heard at all. What the declaration gives is kept.

    It takes the message's bytes and deserialises them itself (what rclpy would do), so the
    slot can keep the bytes for ``%try``: the handler may change its message in place.

    A latched message is handled once: when the subscription turns transient-local (its publishers
    showed up so), the new one is sent the publisher's last messages again, and the old one may
    have heard them live. A message sent before the current subscription opened is dropped when
    one from the same publisher with the same source stamp was handled already.
    """

    #: How many messages' identities (publisher, source stamp) are kept to tell one sent again.
    REMEMBERED = 256

    def __init__(self, process: ProcessNode, node: Node, topic: str, cls: type, slot: HandlerSlot,
                 qos: Qos = Qos(), complain: Optional[Complain] = None) -> None:
        self.topic, self.cls, self.slot = topic, cls, slot
        self._process, self._node, self._declared, self._complain = process, node, qos, complain
        self._lock = threading.Lock()
        self._lane = Lane(slot, complain, topic, process.spinner)
        self._follows = qos.reliability is None and qos.durability is None
        self._handled: dict[tuple[bytes, int], None] = {}  # identities of the last messages, oldest first
        self._publishers = _Publishers(node, topic)
        self.qos = self._wanted() or Qos(qos.depth, qos.reliability or "reliable", qos.durability or "volatile")
        self._sub = self._open(self.qos)
        if self._follows:
            process.watch(self._follow_publishers)
        self._type_name = msgtypes.type_name(cls) or ""
        process.watch_types(topic, self._type_name, complain)

    def _wanted(self) -> Optional[Qos]:
        """The publishers' QoS with the declared depth, if this subscription follows them and they are there."""
        found = _publishers_qos(self._node, self.topic) if self._follows else None
        return None if found is None else Qos(self._declared.depth or found.depth, found.reliability,
                                              found.durability)

    def _open(self, qos: Qos) -> Any:
        self._since = time.time_ns()
        return _made(self._node, lambda: self._node.create_subscription(
            self.cls, self.topic, self._deliver, profile_of(qos), raw=True,
            event_callbacks=_mismatch_report(self._node, self.topic, qos, "subscription", self._complain)))

    def _deliver(self, data: bytes, info: Any) -> None:
        # A transient-local publisher sends its last messages again to a new subscription:
        # they were published before it existed.
        gid = info.get("publisher_gid")
        sender = bytes(gid["data"]) if gid else b""
        came = Arrival(sender.hex() if gid else "?", len(data), info["source_timestamp"] < self._since)
        if self._follows and gid:
            identity = (sender, info["source_timestamp"])
            if came.replayed and identity in self._handled:
                return  # heard before the swap to transient-local: sent again, not published again
            self._handled[identity] = None
            if len(self._handled) > self.REMEMBERED:
                del self._handled[next(iter(self._handled))]
        self._lane(deserialize_message(data, self.cls), Pristine(functools.partial(deserialize_message, data, self.cls)),
                   came)

    def _follow_publishers(self) -> None:
        with self._lock:
            wanted = self._wanted() if self._sub is not None and self._publishers.changed() else None
            if wanted is None or wanted == self.qos:  # no publisher yet, or nothing to change
                return
            for publication in list(self._process.followers.get(self.topic, ())):
                publication.take(wanted)  # first: what this one hears next may be written there
            old, self.qos = self._sub, wanted
            self._sub = self._open(wanted)
            self._node.destroy_subscription(old)

    def connections(self) -> int:
        return self._sub.get_publisher_count()

    def close(self) -> None:
        self._lane.close()
        self._process.unwatch_types(self._complain, self.topic)
        if self._follows:
            self._process.unwatch(self._follow_publishers)
        with self._lock:
            if self._sub is not None:
                self._node.destroy_subscription(self._sub)
                self._sub = None


class Relay:
    """Forward ``source`` to ``target`` as serialized bytes: deserialised only when a guard stands on ``target``
    (``gate``: it reads the values it checks).

    The relay takes the QoS of the publishers it relays, so that wrapping changes
    nothing a subscriber can see: a transient-local (latched) source stays latched
    through it, and a late subscriber still gets the last message, even one the basenode
    sent before the relay matched it; a best-effort source is relayed best-effort (a
    reliable subscription would get nothing from it). The basenode starts after the
    relay, so its QoS is known only once its publisher shows up: the process's graph
    watch tells the relay, which then opens endpoints with that QoS in place of its
    default ones (reliable, volatile).

    ``reader``: the node that subscribes to ``source`` (``node`` unless given), so that its
    executor is the one that passes the messages on (see :class:`ipyros.ros2.actions.ActionRelay`).
    """

    def __init__(self, process: ProcessNode, node: Node, source: str, target: str, cls: type,
                 on_wrong_type: Optional[Callable[[str], None]] = None, complain: Optional[Complain] = None,
                 reader: Optional[Node] = None, gate: Optional[Guarding] = None) -> None:
        self.source, self.target, self.cls, self.count, self.dropped = source, target, cls, 0, 0
        #: A guard's gate: while set, each message is read, checked and sent as the gate says (a guarded relay
        #: reads the values it must check; relays of other topics stay byte relays).
        self.gate = gate
        self._process, self._node, self._reader, self._complain = process, node, reader or node, complain
        self._lock = threading.Lock()  # the watch and close() may swap endpoints from two threads
        self.qos = Qos(None, "reliable", "volatile")  # rclpy's, until the source's publishers show up
        self._last: Optional[bytes] = None
        self._skip: Optional[bytes] = None
        self._publishers = _Publishers(node, source)
        self._pub, self._sub = self._endpoints(self.qos)
        process.watch(self._follow_source)
        process.watch_types(source, msgtypes.type_name(cls) or "", complain)

    def _endpoints(self, qos: Qos) -> tuple[Any, Any]:
        node = self._node
        pub = _made(node, lambda: node.create_publisher(
            self.cls, self.target, profile_of(qos),
            event_callbacks=_mismatch_report(node, self.target, qos, "publication", self._complain)))
        # Until the source's publishers show up, a mismatch with them is expected, and
        # mended by _follow_source: no warning for it.
        from rclpy.event_handler import SubscriptionEventCallbacks

        reader = self._reader
        sub = _made(reader, lambda: reader.create_subscription(
            self.cls, self.source, self._forward, profile_of(qos), raw=True,
            event_callbacks=SubscriptionEventCallbacks(incompatible_qos=lambda _: None)))
        return pub, sub

    def _follow_source(self) -> None:
        """Take the QoS of the source's publishers, if they have shown up and it differs."""
        with self._lock:
            if self._sub is None or not self._publishers.changed():
                return
            wanted = _publishers_qos(self._node, self.source)
            if wanted is None or wanted == self.qos:  # none yet, or a basenode restarting: keep what matched last
                return
            old = self._pub, self._sub
            self.qos = wanted
            self._skip = self._last  # a transient-local source sends its last message again
            self._pub, self._sub = self._endpoints(wanted)
            if self._last is not None and wanted.latched:
                # The last message came before the swap, on the volatile endpoints: the new publisher must
                # hold it for later subscribers. Written now, before a reader of another process has matched this
                # new writer, it is kept in its history and not delivered a second time to those that had it; a
                # reader of this session matches at once and gets it twice (seen; it is one latched message).
                self._pub.publish(self._last)
            self._reader.destroy_subscription(old[1])
            self._node.destroy_publisher(old[0])

    def _forward(self, raw: bytes) -> None:
        if self._skip is not None:
            skip, self._skip = self._skip, None
            if raw == skip:
                return
        gate = self.gate
        if gate is not None and not gate.passes_raw(raw, wire.CDR):  # read whole only when the guard acts on it
            sent = gate.check(deserialize_message(raw, self.cls)).send
            if sent is None:
                return
            raw = serialize_message(sent)
        try:
            self._pub.publish(raw)
        except Exception as error:  # noqa: BLE001 - the middleware refused it (a reliable peer too slow, ...)
            self.dropped += 1
            if self.dropped == 1 and self._complain is not None:
                self._complain(f"{self.target}: the relay could not forward a message ({error}); such drops are "
                               "counted in %status")
            return
        self._last = raw
        self.count += 1

    def send(self, msg: Any) -> None:
        """Send a message object on the target, through the gate if the topic is guarded (``%pub`` on a guarded
        relay, an e-stop)."""
        self._forward(serialize_message(msg))

    def figures(self) -> SendFigures:
        return SendFigures(self.target, "relay", self.count, self._pub.get_subscription_count(), 0, self.dropped)

    def close(self) -> None:
        self._process.unwatch(self._follow_source)
        self._process.unwatch_types(self._complain, self.source)
        with self._lock:
            if self._sub is not None:
                self._reader.destroy_subscription(self._sub)
                self._node.destroy_publisher(self._pub)
                self._sub = None


class Timer:
    """A periodic (or one-shot) callback through a :class:`HandlerSlot` (on its :class:`Lane`)."""

    def __init__(self, node: Node, period: float, slot: HandlerSlot, oneshot: bool = False,
                 complain: Optional[Complain] = None, spinner: Optional[Spinner] = None) -> None:
        self.period, self.slot, self._oneshot = period, slot, oneshot
        self._node = node
        self._lane = Lane(slot, complain, f"timer {slot.label.split(' ', 1)[-1]}", spinner, coalesce=True)
        self._timer = node.create_timer(period, self._tick)

    def _tick(self) -> None:
        if self._oneshot:
            self._timer.cancel()
        self._lane(None)

    def close(self) -> None:
        self._lane.close()
        self._node.destroy_timer(self._timer)


class _Later:
    """What a service callback returns to rclpy instead of a response: "answered elsewhere, later"."""

    __slots__ = ("request",)

    def __init__(self, request: Any) -> None:
        self.request = request


def _serve_later(node: Node, cls: type, name: str, take: Callable[[Any, Any], None]) -> tuple[Any, Callable]:
    """A service whose requests go to ``take(request, header)`` and whose answers are sent by whoever has them.

    rclpy sends what the callback returns; the callback returns a :class:`_Later`, and the
    service's ``send_response`` (replaced here) hands the request on instead of sending it, so
    the executor thread never waits for an answer. Returns the service and rclpy's own send
    (thread-safe in rcl), for the answer.
    """
    service = node.create_service(cls, name, lambda request, response: _Later(request))
    send = service.send_response

    def send_or_hand_over(response: Any, header: Any) -> None:
        if isinstance(response, _Later):
            take(response.request, header)
        else:
            send(response, header)

    service.send_response = send_or_hand_over  # type: ignore[method-assign]
    return service, send


class ServiceServer:
    """A service whose handler is a :class:`HandlerSlot` (it returns the response), run on a thread of its own.

    A service handler may take long (it may even call another service), and on the one
    executor thread it would stop every subscription of the session for that long. So the
    executor only takes the request (:func:`_serve_later`) and hands it to the service's own
    thread, which runs the handler and sends the answer itself.
    Calls to one service are answered in order; the other callbacks never wait for them.
    """

    def __init__(self, node: Node, name: str, cls: type, slot: HandlerSlot) -> None:
        self.name, self.cls, self.slot = name, cls, slot
        self._node = node
        self._requests: "queue.SimpleQueue[Optional[tuple[Any, Any]]]" = queue.SimpleQueue()
        self._service, self._send = _serve_later(node, cls, name, lambda *item: self._requests.put(item))
        self._worker = threading.Thread(target=self._answer, name=f"ipyros-service-{name}", daemon=True)
        self._worker.start()

    def _answer(self) -> None:
        while True:
            item = self._requests.get()
            if item is None:
                return
            request, header = item
            response = self._serve(request, self.cls.Response())  # type: ignore[attr-defined]
            try:
                self._send(response, header)
            except Exception:  # noqa: BLE001 - the service was closed meanwhile, or the caller left
                pass

    def _serve(self, request: Any, response: Any) -> Any:
        # ROS 2 has no error reply: a failing or wrong answer is reported to the session
        # and counted in %status, and the caller gets the default response.
        ok, result = self.slot.run(request)
        if not ok:
            return response
        expected = f"{self.cls.__name__}.Response"
        if not isinstance(result, self.cls.Response):  # type: ignore[attr-defined]
            self.slot.fail(HandlerError(f"the handler of service {self.name} returned {result!r:.60}, which is not "
                                        f"a {expected}; return {expected}(...) with its fields filled"))
            return response
        try:
            return conform(result)
        except MessageTypeError as error:
            self.slot.fail(HandlerError(f"the handler of service {self.name} returned a {expected} that cannot be "
                                        f"sent: {error}"))
            return response

    def close(self) -> None:
        self._requests.put(None)
        self._node.destroy_service(self._service)


#: How long an action's result waits before it goes on to the client (s): the goal's last feedback, on a DDS
#: topic of its own that keeps no order with the result's service, may still be on its way, and an rclpy client
#: drops feedback that comes after the result. The session's action relay and an exported one both wait it.
RESULT_SETTLE = 0.02


class ServiceRelay:
    """Serve ``target`` by calling ``source`` (a basenode's service) and answering with its response.

    Nothing waits for the basenode: each request becomes an asynchronous call from the
    process's caller node (:meth:`ProcessNode.caller`, spun by an executor of its own), and
    the answer is sent when it comes (:func:`_serve_later`), or the default response after
    ``timeout`` seconds (:attr:`TIMEOUT` unless given; None waits as long as it takes). A
    slow basenode stalls neither the session's subscriptions nor other calls to the same
    service. ``settle``: seconds the answer waits first, on a timer's thread, so that the
    caller node's one thread goes on delivering meanwhile (an action's result: :data:`RESULT_SETTLE`).
    """

    TIMEOUT = 10.0  # seconds a basenode may take to answer

    def __init__(self, process: ProcessNode, node: Node, source: str, target: str, cls: type,
                 complain: Optional[Complain] = None, timeout: Optional[float] = TIMEOUT, settle: float = 0.0) -> None:
        self.source, self.target, self.cls, self.timeout, self.settle = source, target, cls, timeout, settle
        self._node, self._caller, self._complain = node, process.caller(), complain
        self._client = self._caller.create_client(cls, source)
        self._service, self._send = _serve_later(node, cls, target, self._call)

    def _call(self, request: Any, header: Any) -> None:
        future = self._client.call_async(request)
        unanswered = threading.Lock()  # taken by the first of answer and expiry

        def answer(done: Any) -> None:
            if done.cancelled() or not unanswered.acquire(blocking=False):
                return
            if expiry is not None:
                expiry.cancel()
            if self.settle:
                later = threading.Timer(self.settle, self._reply, (done.result(), header))
                later.daemon = True
                later.start()
            else:
                self._reply(done.result(), header)

        def expire() -> None:
            if not unanswered.acquire(blocking=False):
                return
            self._client.remove_pending_request(future)
            if self._complain is not None:
                self._complain(f"{self.target}: the basenode's service did not answer within {self.timeout:g} s; "
                               "the caller got an empty response (see its log: nd.base.tail())")
            self._reply(self.cls.Response(), header)  # type: ignore[attr-defined]  # ROS 2 has no error reply

        expiry = None if self.timeout is None else threading.Timer(self.timeout, expire)
        if expiry is not None:  # none for an action's result, which comes when the goal ends
            expiry.daemon = True
            expiry.start()
        future.add_done_callback(answer)

    def _reply(self, response: Any, header: Any) -> None:
        try:
            self._send(response, header)
        except Exception:  # noqa: BLE001 - the relay was closed meanwhile, or the caller left
            pass

    def close(self) -> None:
        self._node.destroy_service(self._service)
        self._caller.destroy_client(self._client)


# -- the graph: a node's interface, as discovery sees it ---------------------------------------

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


# -- parameters: a node's own, by global name ----------------------------------------------

_INT64 = range(-2**63, 2**63)


def check_param(name: str, value: Any) -> None:
    """Refuse, in one line, a value a ROS 2 parameter cannot hold.

    bool, 64-bit int, float, str, bytes, and lists of one of bool, int, float or str.
    """
    if value is None:
        raise DeclarationError(f"parameter {name} = None: a ROS 2 parameter cannot be unset that way; "
                               "use del nd.params[...]")
    if isinstance(value, (bool, float, str, bytes)):
        return
    if isinstance(value, int):
        if value not in _INT64:
            raise DeclarationError(f"parameter {name} = {cut(value)} does not fit the 64-bit integer a ROS 2 parameter "
                                   "holds; pass it as a float or a string")
        return
    if isinstance(value, (list, tuple)):
        kinds = {bool if isinstance(v, bool) else type(v) for v in value}
        if not (len(kinds) <= 1 and kinds <= {bool, int, float, str}):
            raise DeclarationError(f"parameter {name} = {cut(value)}: a ROS 2 parameter list holds one type "
                                   "(bool, int, float or str)")
        wide = next((v for v in value if kinds == {int} and v not in _INT64), None)
        if wide is not None:
            raise DeclarationError(f"parameter {name} = {cut(value)}: its item {cut(wide)} does not fit the 64-bit "
                                   "integers a ROS 2 parameter list holds; pass floats or strings")
        return
    raise DeclarationError(f"parameter {name} = {cut(value)} is a {type(value).__name__}: a ROS 2 parameter "
                           "holds bool, int, float, str, bytes or a list of one of those")


class ParamWatch:
    """Tell ``tell(value)`` each time the parameter ``key`` of ``node`` (a node of this process) is set, by
    anyone: a ``ros2 param set``, another node's SetParameters call, or this session (rclpy's post-set callback)."""

    def __init__(self, node: Node, key: str, tell: Callable[[Any], None]) -> None:
        self._node, self.key, self.tell = node, key, tell
        node.add_post_set_parameters_callback(self._set)

    def _set(self, parameters: list[Any]) -> None:
        for parameter in parameters:
            if parameter.name == self.key:
                self.tell(parameter.value)

    def close(self) -> None:
        self._node.remove_post_set_parameters_callback(self._set)

