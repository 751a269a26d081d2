"""The live endpoints of the session's DSL nodes on ROS 1, hosted in its one rospy node (:mod:`ipyros.ros1.runtime`):
publications, subscriptions, relays, timers (services: :mod:`ipyros.ros1.services`). Each is a small object with a
``close()``; the DSL decides which exist (see :mod:`ipyros.core.plan`), this module only opens and closes them.

Performance choices (measured in bench/relay.py):
- publishers are synchronous (``queue_size=None``): no hand-off to a publisher thread;
  the bytes go to each connection through :mod:`ipyros.ros1.sending`, where a subscriber that
  cannot keep up gets a bounded backlog of its own instead of blocking the writer;
- relays subscribe with :class:`rospy.AnyMsg` and write the received bytes as they are,
  through a publisher advertised up front with the concrete class, so the type, md5 and
  message definition are right from the first message and none is lost at start;
- subscribers have an unbounded queue: rospy's ``queue_size=N`` drops bursts;
- every subscription reads bytes (rospy has one per topic per process, so a relay and a
  handler on one topic must agree); a handler's message is deserialised for it alone.
"""

from __future__ import annotations

import functools
import io
import logging
import os
import re
import threading
import warnings
import xmlrpc.client
from typing import Any, Callable, Optional

import genpy
import rospy
from rospy.msg import serialize_message

from ..core import msgtypes, wire
from ..core.errors import DeclarationError, MessageTypeError, NodeStateError
from ..core.guard import Guarding
from ..core.msgbuild import explain_unsendable
from ..core.slots import Arrival, HandlerSlot, Pristine, SendFigures
from . import cutthrough, rospy_inside, sending
from .master import master_proxy
from .reconnect import Reconnect

__all__ = ["Publication", "RawRelay", "Relay", "Subscription", "Timer", "raw_class"]


def _publisher(topic: str, cls: type, latch: bool = False) -> rospy.Publisher:
    """A synchronous publisher (``queue_size=None`` on purpose; see the module docstring)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*queue_size", category=SyntaxWarning)
        return rospy.Publisher(topic, cls, latch=latch, queue_size=None)


# rospy reads with sock.recv(buff_size) and CPython allocates that much per call: from
# 128 KiB on glibc serves it with mmap/munmap (~15 µs a read, per small message); just
# under costs ~1.5 µs and still reads a 1 MiB image in 8 calls (bench/README.md).
_BUFF_SIZE = 127 * 1024


#: How long a relay's message waits for another connection's message going out in parts
#: (a 1 MiB image takes milliseconds; a publisher stalled in mid-message must not stall this one for ever).
_PARTS_WAIT = 2.0


class Publication:
    """A publisher whose ``write`` serialises and sends in the caller's thread, never blocking.

    The message is serialised into a buffer of its own before any connection is touched:
    a message that cannot be serialised (a field of the wrong type, a time out of range)
    is refused with one line and leaves every connection as it was. (rospy's own publish
    serialises into the publisher's shared buffer and, when that fails, leaves the half
    message there for good: every later message reaches the subscribers corrupted.) The
    bytes then go out through :mod:`ipyros.ros1.sending`, where a slow subscriber queues and
    loses its own oldest messages instead of blocking the writer.
    """

    def __init__(self, topic: str, cls: type, latch: bool = False, follows: Optional[str] = None,
                 gate: Optional[Guarding] = None) -> None:
        self.topic, self.cls = topic, cls
        self.count = 0
        self._pub = _publisher(topic, cls, latch)
        self._impl = rospy_inside.impl_of(self._pub)
        self._follows = follows  # a topic whose latching this one takes: latched once a message came latched on it
        #: A guard's gate every message passes first (``check(msg)``: what to send, or nothing), or None.
        self.gate = gate

    def write(self, msg: Any) -> None:
        if not isinstance(msg, genpy.Message) or msg._md5sum != self.cls._md5sum:
            # A class is not a message; a message of the same name but another md5 (another
            # version of its package) would be read as garbage by every subscriber.
            got = getattr(msg, "_type", None) or type(msg).__name__
            what = f"the class {got}" if isinstance(msg, type) else f"a {got} of another definition" \
                if got == self.cls._type else got
            raise MessageTypeError(f"{self.topic} carries {self.cls._type}, not {what}; "
                                   f"write a message: {self.cls.__name__}(...)")
        gate = self.gate
        if gate is not None:
            msg = gate.check(msg).send
            if msg is None:  # dropped by the guard
                return
        impl = self._impl
        impl.acquire()
        try:
            if impl.closed:
                raise NodeStateError(f"the publisher of {self.topic} was closed; declare the topic again")
            buffer = io.BytesIO()
            try:
                serialize_message(buffer, impl.seq + 1, msg)
            except Exception as error:  # genpy's SerializationError, struct.error, TypeError, ...
                why = explain_unsendable(msg) or f"{_first_line(error)}; nothing was sent: check the field types " \
                                                 "and ranges"
                raise MessageTypeError(f"cannot send this {self.cls._type} on {self.topic}: {why}") from None
            impl.seq += 1
            if self._follows is not None and not impl.is_latch and self._follows in _latched_topics:
                impl.enable_latch()
            if impl.is_latch:
                impl.latch = msg  # rospy sends it to a subscriber connecting later
            with buffer.getbuffer() as framed:  # sent as it is: no copy of a large message
                sending.send_framed_to_all(impl.connections, self.topic, framed)
            impl.message_data_sent += buffer.tell()
            self.count += 1
        finally:
            impl.release()

    def connections(self) -> int:
        return self._pub.get_num_connections()

    def figures(self) -> SendFigures:
        return _send_figures(self.topic, "publish", self.count, self._impl)

    def close(self) -> None:
        self._pub.unregister()


def _send_figures(topic: str, kind: str, count: int, impl: Any) -> SendFigures:
    backlog = sending.backlog(topic)
    return SendFigures(topic, kind, count, len(impl.connections), backlog.messages, backlog.dropped)


def _offer_again(impl: Any) -> None:
    """Register this process's publication ``impl`` with the master again, in a moment and once more later.

    The master then sends every subscriber of its topic the list of its publishers, and one
    whose connection to this process was just closed connects again: rospy subscribers do not
    by themselves when a publisher closes their connection (roscpp ones do). Its first try waits
    for the subscriber to notice the closed connection; the second is for one busy in a callback.
    A publication closed meanwhile is not registered again (it would stay on the master as a dead entry).
    """
    topic, type_name = impl.resolved_name, impl.type

    def offer() -> None:
        if impl.closed or rospy.is_shutdown():
            return
        try:
            master = master_proxy(os.environ["ROS_MASTER_URI"], timeout=5.0)
            master.registerPublisher(rospy.get_name(), topic, type_name, rospy_inside.node_uri())
            if impl.closed:  # it closed while it was being registered: take it back
                master.unregisterPublisher(rospy.get_name(), topic, rospy_inside.node_uri())
        except Exception:  # noqa: BLE001 - the master is away: when it is back, everything is registered again
            pass

    for delay in (0.5, 5.0):
        timer = threading.Timer(delay, offer)
        timer.daemon = True
        timer.start()


def _first_line(error: BaseException) -> str:
    text = str(error).strip().splitlines()
    return text[0] if text else type(error).__name__


def _subscribe_bytes(topic: str, cls: type, callback: Callable[[Any], None]) -> rospy.Subscriber:
    """A rospy subscriber that hands ``callback`` the message's bytes (a :func:`raw_class` of ``cls``).

    rospy keeps one subscription per topic in a process, with the message class of whoever
    subscribed first, and hands every callback of the topic that class. So every reader in
    this session subscribes the same way, as bytes: a relay forwards them, a typed
    :class:`Subscription` deserialises its own message from them. A relay and a handler (and
    ``%echo``) on one topic then each get what they asked for, in either order. A topic
    already read here as another type is refused: its bytes would not parse.
    """
    existing = rospy_inside.subscriber_impl(topic)
    if existing is not None and existing.data_class._type != cls._type:
        raise DeclarationError(f"{topic} is already read in this session as {existing.data_class._type}, "
                               f"so it cannot be read as {cls._type} too: use {existing.data_class._type}")
    sub = rospy.Subscriber(topic, raw_class(cls), callback, queue_size=None, buff_size=_BUFF_SIZE,
                           tcp_nodelay=True)
    cutthrough.reading(rospy_inside.impl_of(sub))  # large messages read straight into one buffer
    Reconnect.guard(sub)
    _OtherTypes.install()
    return sub


class _OtherTypes(logging.Handler):
    """Tells the user, once per peer, of a publisher whose type differs from a subscription's here.

    rospy subscribes with the declared type and md5, and a publisher of another type
    refuses the connection: nothing passes, which is right, but rospy only writes it to its
    log file ("Client [...] wants topic [...] to have datatype/md5sum [...], but our version
    has [...]") and tries again and again. This handler on rospy's internal logger reads
    that line and tells each subscription's ``complain`` who the peer is and both types.
    """

    # What a rospy publisher answers (tcpros_pubsub): the types, or (same name) the md5sums, differ.
    _LINES = (re.compile(r"topic types do not match: \[(?P<wanted>[^\]]*)\] vs\. \[(?P<theirs>[^\]]*)\]"),
              re.compile(r"wants topic \[(?P<topic>[^\]]+)\] to have datatype/md5sum \[(?P<wanted>[^\]]*?)/\w+\], "
                         r"but our version has \[(?P<theirs>[^\]]*?)/\w+\]"))
    _installed = False
    watchers: dict[str, list[tuple[str, Callable[[str], None]]]] = {}  # topic → (declared type, complain)
    told: set[tuple[str, str, Callable[[str], None]]] = set()

    @classmethod
    def install(cls) -> None:
        if not cls._installed:
            rospy_inside.listen_to_internal_log(cls(level=logging.ERROR))
            cls._installed = True

    @classmethod
    def watch(cls, topic: str, type_name: str, complain: Optional[Callable[[str], None]]) -> None:
        if complain is not None:
            cls.watchers.setdefault(topic, []).append((type_name, complain))

    @classmethod
    def unwatch(cls, topic: str, complain: Optional[Callable[[str], None]]) -> None:
        cls.watchers[topic] = [w for w in cls.watchers.get(topic, []) if w[1] is not complain]

    def emit(self, record: logging.LogRecord) -> None:
        try:
            text = record.getMessage()
        except Exception:  # noqa: BLE001 - a record that does not format is not ours
            return
        found = next((m for m in (line.search(text) for line in self._LINES) if m is not None), None)
        if found is None:
            return
        wanted, theirs = found["wanted"], found["theirs"]
        topic = found.groupdict().get("topic") or rospy_inside.connecting_topic()
        for declared, complain in list(self.watchers.get(topic or "", ())):
            if declared != wanted or (topic, theirs, complain) in self.told:
                continue
            self.told.add((topic, theirs, complain))
            peers = _publishers_of_type(topic, theirs)
            complain(msgtypes.another_type_line(topic, ", ".join(peers) or "a publisher", theirs, declared, "ROS"))


def _publishers_of_type(topic: str, type_name: str) -> list[str]:
    """The nodes that publish ``topic`` as ``type_name`` (each asked, as rostopic info would)."""
    found = []
    try:
        master = master_proxy(os.environ["ROS_MASTER_URI"], timeout=2.0)
        _, _, (publishers, _, _) = master.getSystemState(rospy.get_name())
        for name in dict(publishers).get(topic, ()):
            code, _, uri = master.lookupNode(rospy.get_name(), name)
            if code == 1:
                _, _, topics = master_proxy(uri, timeout=2.0).getPublications(rospy.get_name())
                if [topic, type_name] in [list(t) for t in topics]:
                    found.append(name)
    except (OSError, KeyError, ValueError, xmlrpc.client.Error):
        pass
    return found


def _message(cls: type, buff: bytes, header: dict) -> Any:
    msg = cls()
    msg.deserialize(buff)
    msg._connection_header = header  # who sent it, latched or not: as rospy gives it
    return msg


#: The topics this process has received from a latching publisher: an output taken over from a
#: basenode (a map, a robot description) stays latched when its source is (:class:`Publication`).
_latched_topics: set[str] = set()


class Subscription:
    """A typed subscriber whose callback is a :class:`HandlerSlot`.

    Each subscription deserialises the message itself, from the bytes the topic's one rospy
    subscription received (see :func:`_subscribe_bytes`), so each handler has a message of
    its own, as nodes in separate processes would: the paper's ``controlVelocity`` edits
    ``data`` in place and publishes it, and another node of the session still sees the
    original. (Deserialising is also quicker than rospy's shared message plus a deepcopy.)
    """

    def __init__(self, topic: str, cls: type, slot: HandlerSlot, complain: Optional[Callable[[str], None]] = None) -> None:
        self.topic, self.cls, self.slot = topic, cls, slot
        self._connections: dict[int, dict] = {}  # the header of each connection a message came on
        self._sub = _subscribe_bytes(topic, cls, self._deliver)
        self._complain = complain
        _OtherTypes.watch(topic, cls._type, complain)

    def _deliver(self, raw: rospy.AnyMsg) -> None:
        header = raw._connection_header
        first = id(header) not in self._connections  # a latched publisher sends its last message on connecting
        if first:
            self._remember(header)
            if header.get("latching") == "1":
                _latched_topics.add(self.topic)
        self.slot.run(_message(self.cls, raw._buff, header),
                      Pristine(functools.partial(_message, self.cls, raw._buff, header)),
                      Arrival(header.get("callerid", "?"), len(raw._buff), first and header.get("latching") == "1"))

    def _remember(self, header: dict) -> None:
        """Note a connection by its header (kept: its id stays unique while it is a key); the
        headers of connections that are gone are dropped now and then, so they do not pile up."""
        sub = getattr(self, "_sub", None)  # None while rospy hands a latched message to the new callback
        if sub is not None and len(self._connections) >= 16:
            self._connections = {id(c.header): c.header for c in rospy_inside.impl_of(sub).connections if getattr(c, "header", None)}
        self._connections[id(header)] = header

    def connections(self) -> int:
        return self._sub.get_num_connections()

    def close(self) -> None:
        _OtherTypes.unwatch(self.topic, self._complain)
        self._sub.unregister()


_raw_classes: dict[type, type] = {}


def raw_class(cls: type) -> type:
    """An :class:`rospy.AnyMsg` that says it is ``cls``: bytes in, no deserialising.

    With plain AnyMsg the master records the subscription as "*" (``rosnode info``
    shows "unknown type") and any publisher may connect; this one registers the real
    type and md5, so tools show it and a publisher of another type is refused.
    """
    raw = _raw_classes.get(cls)
    if raw is None:
        raw = type(f"Raw{cls.__name__}", (rospy.AnyMsg,), {
            "__slots__": (), "_type": cls._type, "_md5sum": cls._md5sum, "_full_text": cls._full_text,
            # False: rospy would set header.seq on a message it has not parsed; bytes pass unchanged.
            "_has_header": False})
        _raw_classes[cls] = raw
    return raw


class Relay:
    """Forward ``source`` to ``target`` unchanged, without deserialising.

    Latching follows the source: once a latched message arrives, the target latches too.
    Messages of another type than declared are dropped, and ``on_wrong_type(type)`` is
    told once: forwarding them would put bytes of one type under another's name.
    """

    def __init__(self, source: str, target: str, cls: type,
                 on_wrong_type: Optional[Callable[[str], None]] = None,
                 complain: Optional[Callable[[str], None]] = None, gate: Optional[Guarding] = None) -> None:
        self.source, self.target, self.cls = source, target, cls
        self._complain = complain
        #: A guard's gate: while set, each message is read, checked and sent as the gate says (a guarded relay
        #: reads the values it must check; relays of other topics stay byte relays).
        self.gate = gate
        self.count = 0
        self.dropped = 0
        self._type = cls._type
        self._on_wrong_type = on_wrong_type
        self._header_seen: Optional[dict] = None
        self._pub = _publisher(target, cls)
        self._impl = rospy_inside.impl_of(self._pub)
        try:
            self._read(source, cls)
        except DeclarationError:
            self._pub.unregister()
            raise
        _OtherTypes.watch(source, cls._type, complain)

    def _read(self, source: str, cls: type) -> None:
        """Subscribe to ``source`` as bytes; large messages go on while they arrive (:mod:`.cutthrough`)."""
        self._sending = threading.Lock()  # held while a message goes out in parts
        self._sent_in_parts: set[int] = set()  # ids of whole messages whose bytes already went out
        self._sub = _subscribe_bytes(source, cls, self._forward)
        self._reading = cutthrough.reading(rospy_inside.impl_of(self._sub))
        if self._reading.sink is None:
            self._reading.sink = self

    def _accepts(self, header: dict) -> bool:
        """Whether messages of the incoming connection of ``header`` are forwarded."""
        if header is not self._header_seen:  # once per incoming connection, not per message
            if header.get("type") != self._type:
                self._wrong_type(header.get("type", "?"))
                return False
            if header.get("latching") == "1" and not self._impl.is_latch:
                self._impl.enable_latch()
            self._header_seen = header
        return True

    def _forward(self, raw: rospy.AnyMsg) -> None:
        impl = self._impl
        if self._sent_in_parts and id(raw) in self._sent_in_parts:  # its bytes went out as they came
            self._sent_in_parts.discard(id(raw))
            if impl.is_latch:
                impl.latch = raw
            self.count += 1
            return
        header = raw._connection_header
        if header is not self._header_seen and not self._accepts(header):
            return
        # A message going out in pieces (from another connection) has the outgoing streams until it ends.
        # Unlocked, none can start while this one goes: begin() takes the lock, then sees two connections.
        if self._sending.locked() and not self._wait_for_pieces():
            return
        gate = self.gate
        if gate is not None and not gate.passes_raw(raw._buff, wire.ROS1):  # read whole only when the guard acts on it
            self.send(_message(self.cls, raw._buff, header))
            return
        impl.acquire()
        try:
            if impl.is_latch:
                impl.latch = raw  # what a subscriber connecting later gets first
            sending.send_to_all(impl.connections, self.target, raw._buff)
        finally:
            impl.release()
        self.count += 1

    def send(self, msg: Any) -> None:
        """Send a message object on the target, through the gate if the topic is guarded (a guarded relay's own
        messages, ``%pub`` and an e-stop on a guarded relay)."""
        gate = self.gate
        if gate is not None:
            msg = gate.check(msg).send
            if msg is None:
                return
        buffer = io.BytesIO()
        msg.serialize(buffer)
        impl = self._impl
        impl.acquire()
        try:
            if impl.is_latch:
                impl.latch = msg
            sending.send_to_all(impl.connections, self.target, buffer.getvalue())
        finally:
            impl.release()
        self.count += 1

    def _wait_for_pieces(self) -> bool:
        if self._sending.acquire(True, _PARTS_WAIT):
            self._sending.release()
            return True
        sending.count_dropped(self.target)  # its publisher stalled in mid-message
        return False

    # -- cutthrough.FrameSink: a large message sent on while it arrives -----------------------
    def begin(self, header: dict, size: int) -> Optional[sending.Frame]:
        impl = self._impl
        if impl is None or self.gate is not None or not self._sending.acquire(False):  # a guard reads it whole
            return None
        frame = None
        if len(self._reading.sub_impl.connections) == 1 and self._accepts(header):
            impl.acquire()
            try:
                frame = sending.Frame(impl.connections, self.target, size) if impl.connections else None
            finally:
                impl.release()
        if frame is None:
            self._sending.release()
        return frame

    def end(self, frame: sending.Frame, message: Any) -> None:
        frame.close()
        self._sent_in_parts.add(id(message))
        self._sending.release()

    def abort(self, frame: sending.Frame) -> None:
        frame.abort()  # the subscribers' connections are closed: their streams were cut mid-message
        sending.count_dropped(self.target)
        self._sending.release()
        _offer_again(self._impl)

    def _wrong_type(self, got: str) -> None:
        self.dropped += 1
        if self.dropped == 1 and self._on_wrong_type is not None:
            self._on_wrong_type(got)

    def figures(self) -> SendFigures:
        return _send_figures(self.target, "relay", self.count, self._impl)

    def peers(self) -> tuple[int, int]:
        """How many publishers of the source it reads and subscribers of the target it writes to, now."""
        return len(self._reading.sub_impl.connections), len(self._impl.connections) if self._impl is not None else 0

    def close(self) -> None:
        _OtherTypes.unwatch(self.source, self._complain)
        if self._reading.sink is self:
            self._reading.sink = None
        self._sub.unregister()
        if self._pub is not None:  # a RawRelay advertises at its first message
            self._pub.unregister()


class RawRelay(Relay):
    """A relay of a type this Python cannot import (a workspace's own, a package not installed here).

    TCPROS carries bytes: they are forwarded as they came, and the target is advertised with
    the type, md5 and definition of the publisher the first message came from (its connection
    header says them), as topic_tools' relay does; so the target shows up with that message.
    """

    def __init__(self, source: str, target: str, type_name: str,
                 on_wrong_type: Optional[Callable[[str], None]] = None,
                 complain: Optional[Callable[[str], None]] = None) -> None:
        self.source, self.target, self.cls = source, target, None
        self._complain, self._on_wrong_type = complain, on_wrong_type
        self.gate = None  # a guard reads values: a type this Python lacks cannot be guarded
        self.count = self.dropped = 0
        self._type = type_name
        self._header_seen: Optional[dict] = None
        self._pub: Any = None
        self._impl: Any = None
        # Subscribed as "any md5" under the declared type: the master and rosnode show the type.
        stand_in = type("Unknown", (rospy.AnyMsg,), {"__slots__": (), "_type": type_name, "_md5sum": "*",
                                                     "_full_text": "", "_has_header": False})
        self._read(source, stand_in)
        _OtherTypes.watch(source, type_name, complain)

    def _forward(self, raw: rospy.AnyMsg) -> None:
        if self._pub is None:
            header = raw._connection_header
            if header.get("type") != self._type:
                self._wrong_type(header.get("type", "?"))
                return
            described = type("Described", (rospy.AnyMsg,), {
                "__slots__": (), "_type": header["type"], "_md5sum": header.get("md5sum", "*"),
                "_full_text": header.get("message_definition", ""), "_has_header": False})
            self._pub = _publisher(self.target, described)
            self._impl = rospy_inside.impl_of(self._pub)
        super()._forward(raw)

    def figures(self) -> SendFigures:
        if self._impl is None:
            return SendFigures(self.target, "relay", 0, 0, 0, self.dropped)
        return super().figures()


class Timer:
    """A periodic (or one-shot) callback through a :class:`HandlerSlot`."""

    def __init__(self, period: float, slot: HandlerSlot, oneshot: bool = False) -> None:
        self.period, self.slot = period, slot
        self._timer = rospy.Timer(rospy.Duration.from_sec(period), slot, oneshot=oneshot)

    def close(self) -> None:
        self._timer.shutdown()
