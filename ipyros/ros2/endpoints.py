"""A ROS 2 node's endpoints in the session: publications, subscriptions, relays of topics and services, timers,
services (see :mod:`ipyros.ros2.runtime` for the process and its nodes).

Endpoints mirror :mod:`ipyros.ros1.runtime`'s: each has ``close()``; handlers go through a
:class:`~ipyros.core.slots.HandlerSlot`; relays forward serialized bytes (``raw=True``), reading a message whole
only when a guard stands on the output and acts on it (it reads the numbers it checks in the bytes first:
:mod:`ipyros.core.wire`).
"""

from __future__ import annotations

import functools
import queue
import threading
import time
from typing import TYPE_CHECKING, Any, Callable, Optional

from rclpy._rclpy_pybind11 import RCLError
from rclpy.node import Node
from rclpy.serialization import deserialize_message, serialize_message

from ..core import msgtypes, wire
from ..core.errors import HandlerError, MessageTypeError, NodeStateError
from ..core.guard import Guarding
from ..core.msgbuild import conform
from ..core.qos import Qos
from ..core.slots import Arrival, HandlerSlot, Pristine, SendFigures
from .qosmatch import Complain, mismatch_report, profile_of, qos_of
from .spinning import Lane, Spinner

if TYPE_CHECKING:
    from .runtime import ProcessNode

__all__ = ["RESULT_SETTLE", "Publication", "Relay", "ServiceRelay", "ServiceServer", "Subscription", "Timer"]


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
            self.cls, topic, profile_of(qos), event_callbacks=mismatch_report(node, topic, qos, "publication",
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
            event_callbacks=mismatch_report(self._node, self.topic, qos, "subscription", self._complain)))

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
            event_callbacks=mismatch_report(node, self.target, qos, "publication", self._complain)))
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
