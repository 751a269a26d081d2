"""Sending serialized messages to subscriber connections, never blocking on a slow one.

A publisher of this session writes each message to every subscriber connection itself
(no rospy publisher thread: that hand-off costs latency, bench/README.md). rospy's own
``sendall`` would block the writer as long as the slowest subscriber's socket is full: one
subscriber whose callback sleeps froze ``write()``, the prompt, a relay and every other
subscriber of the topic. So each connection gets an :class:`Outbox`:

- **fast path**: the socket takes the whole message now (``MSG_DONTWAIT``): sent in the
  caller's thread, as before, at the same cost;
- **slow path**: what the socket did not take goes into the connection's own backlog,
  which a writer thread of that connection drains with blocking sends. Later messages
  for that connection queue behind it (order is kept), so the caller does not wait.
- **full backlog**: it holds ``limit`` messages (and ``limit_bytes``). When it is full and
  the subscriber still reads (its writer sent something in the last ``STALLED`` seconds),
  the caller waits for room (``ROOM_WAIT`` at most), as behind a direct connection: a subscriber that is
  only slower than the sender (a relay flat out) loses nothing. When the subscriber reads
  nothing (a callback asleep), the oldest message not yet begun is dropped and counted,
  as ROS users know from ``queue_size``, and the caller goes on. A message that has begun
  to go out is never dropped: the stream would be cut in the middle of a frame.

A message may also be sent while it still arrives (a relay forwarding a large image as
its parts come in, :mod:`.cutthrough`): a :class:`Frame` opens it on every connection,
sends its parts as they come and closes it. Until it is closed, nothing else goes out on
those connections ahead of its remaining parts.

Counts are kept per topic (:func:`dropped`, :func:`backlog`), for ``%status``.
"""

from __future__ import annotations

import socket
import struct
import threading
import time
import weakref
from collections import deque
from dataclasses import dataclass, field
from typing import Any, Iterable

__all__ = ["Backlog", "Frame", "Outbox", "backlog", "count_dropped", "dropped", "outbox", "send_framed_to_all",
           "send_to_all"]

#: Messages a slow connection may have waiting before its oldest are dropped.
LIMIT = 100
#: Bytes a slow connection may have waiting (1 MiB images: 32 of them).
LIMIT_BYTES = 32 * 1024 * 1024
#: A subscriber whose connection took nothing for this long is not reading: its oldest waiting
#: messages are dropped instead of holding the sender back.
STALLED = 0.5
#: The longest a sender waits for room behind one message (a subscriber that reads a trickle).
ROOM_WAIT = 2.0
#: How long the writer of a message still arriving waits for its next part before it
#: checks again (the part's sender wakes it at once; this only bounds a lost wake-up).
_PART_WAIT = 0.5

_outboxes: "weakref.WeakKeyDictionary[Any, Outbox]" = weakref.WeakKeyDictionary()
_outboxes_lock = threading.Lock()
_dropped: dict[str, int] = {}  # topic → messages dropped for slow subscribers, ever
_counts_lock = threading.Lock()
_LENGTH = struct.Struct("<I")


@dataclass(frozen=True)
class Backlog:
    """What waits on one topic's slow connections now."""

    connections: int  # connections with something waiting
    messages: int
    dropped: int  # dropped on this topic so far


@dataclass(eq=False)
class _Waiting:
    """One message in a backlog: the parts not sent yet (the first may be partly sent)."""

    parts: deque = field(default_factory=deque)
    size: int = 0  # the whole message's bytes, length prefix included
    complete: bool = True  # False while its parts still arrive
    begun: bool = False  # some of it is on the wire: it must go out whole

    @property
    def pending(self) -> int:
        return sum(len(p) for p in self.parts)


class Outbox:
    """The sending side of one subscriber connection (a rospy ``TCPROSTransport``)."""

    def __init__(self, conn: Any, topic: str, limit: int = LIMIT, limit_bytes: int = LIMIT_BYTES) -> None:
        self.conn, self.topic = conn, topic
        self.limit, self.limit_bytes = limit, limit_bytes
        self._waiting: deque[_Waiting] = deque()
        self._open: _Waiting | None = None  # the message being sent in parts, when it waits here
        self._open_size: int | None = None  # its size while a message is being sent in parts (queued or not)
        self._bytes = 0
        self._lock = threading.Lock()
        self._wake = threading.Condition(self._lock)  # the writer: more to send
        self._room = threading.Condition(self._lock)  # a sender waiting for the backlog to shrink
        self._progress = 0.0  # when the writer last sent something (monotonic)
        self._writer: threading.Thread | None = None

    @property
    def waiting(self) -> int:
        return len(self._waiting)

    def send(self, parts: tuple[bytes, ...], size: int) -> None:
        """Send one length-prefixed message (``parts`` joined are ``size`` bytes); waits only for room
        behind a full backlog that a subscriber is reading (see the module's docstring)."""
        sock = self._socket()
        if sock is None:
            return
        with self._lock:
            if not self._waiting and self._open_size is None:
                sent = self._try_send(sock, parts)
                if sent is None or sent == size:
                    if sent == size:
                        self._count(size)
                    return
                rest = memoryview(b"".join(parts))[sent:]
                self._queue(_Waiting(deque([rest]), size, begun=sent > 0))
            else:
                if self._open_size is not None and self._open is None:  # the open message's rest stays ahead
                    self._open = self._queue(_Waiting(size=self._open_size, complete=False, begun=True))
                self._queue(_Waiting(deque([memoryview(b"".join(parts))]), size))
            self._start_writer()

    # -- a message sent in parts ------------------------------------------------------------
    def open(self, size: int) -> None:
        """A message of ``size`` bytes (length prefix included) will come in parts (:meth:`part`)."""
        with self._lock:
            self._open_size = size

    def part(self, data: memoryview) -> None:
        """Send the open message's next bytes; what the socket does not take now waits (copied)."""
        sock = self._socket()
        if sock is None:
            return
        with self._lock:
            if self._open_size is None:
                return
            if self._open is None and not self._waiting:
                sent = self._try_send(sock, (data,))
                if sent is None or sent == len(data):
                    return
                self._open = self._queue(_Waiting(size=self._open_size, complete=False, begun=True))
                data = data[sent:]
            elif self._open is None:  # behind earlier messages: none of it is sent yet
                self._open = self._queue(_Waiting(size=self._open_size, complete=False))
            self._open.parts.append(memoryview(bytes(data)))
            self._bytes += len(data)
            self._start_writer()

    def close_frame(self) -> None:
        """All of the open message has been given: it is counted once it is all sent."""
        with self._lock:
            if self._open_size is None:
                return
            if self._open is None:
                self._count(self._open_size)
            else:
                self._open.complete = True
                self._wake.notify()
            self._open = self._open_size = None

    def abort_frame(self) -> None:
        """The open message will never be whole: the subscriber's stream is cut, so the connection is closed
        (its subscriber connects again and gets the next message whole)."""
        with self._lock:
            opened = self._open_size is not None
            self._open = self._open_size = None
            self._waiting.clear()
            self._bytes = 0
            self._wake.notify()
            self._room.notify_all()
        if opened:
            self._close()

    # -- the backlog --------------------------------------------------------------------------
    def _socket(self) -> Any:
        sock = getattr(self.conn, "socket", None)
        return None if sock is None or getattr(self.conn, "done", False) else sock

    def _try_send(self, sock: Any, parts: tuple) -> int | None:
        """What the socket takes now without waiting; None when the connection is broken (then closed)."""
        try:
            return sock.sendmsg(parts, (), socket.MSG_DONTWAIT)
        except BlockingIOError:
            return 0
        except OSError:
            self._close()
            return None

    def _queue(self, item: _Waiting) -> _Waiting:
        self._waiting.append(item)
        self._bytes += item.pending
        deadline = time.monotonic() + ROOM_WAIT
        while len(self._waiting) > self.limit or self._bytes > self.limit_bytes:
            # The oldest message not begun and not still arriving can go; the newest always stays.
            droppable = [w for w in list(self._waiting)[:-1] if not w.begun and w.complete]
            if not droppable:
                break
            now = time.monotonic()
            if self._writer is not None and now - self._progress < STALLED and now < deadline:
                self._room.wait(STALLED)  # the subscriber reads, only slower: wait for room
                continue
            self._waiting.remove(droppable[0])
            self._bytes -= droppable[0].pending
            count_dropped(self.topic)
        return item

    def _start_writer(self) -> None:
        if self._writer is None or not self._writer.is_alive():
            self._progress = time.monotonic()
            self._writer = threading.Thread(target=self._drain, name=f"ipyros-outbox {self.topic}", daemon=True)
            self._writer.start()
        self._wake.notify()

    def _drain(self) -> None:
        """The writer thread: blocking sends of the backlog, head first, until it is empty."""
        sock = self.conn.socket
        while True:
            with self._lock:
                while self._waiting and not self._waiting[0].parts and not self._waiting[0].complete:
                    self._wake.wait(_PART_WAIT)  # the head still arrives: its next part comes
                if not self._waiting:
                    self._writer = None
                    self._room.notify_all()
                    return
                head = self._waiting[0]
                if not head.parts:  # whole and all sent
                    self._waiting.popleft()
                    self._count(head.size)
                    continue
                data = head.parts[0]
            try:
                sent = sock.send(data)  # blocks until the peer reads: only this thread waits
            except OSError:
                with self._lock:
                    self._waiting.clear()
                    self._bytes = 0
                    self._open = self._open_size = None
                    self._writer = None
                    self._room.notify_all()
                self._close()
                return
            with self._lock:
                if sent:
                    self._progress = time.monotonic()
                    self._room.notify_all()
                if not self._waiting or self._waiting[0] is not head:
                    continue  # aborted meanwhile
                head.begun = True
                self._bytes -= sent
                if sent == len(data):
                    head.parts.popleft()
                else:
                    head.parts[0] = data[sent:]

    def _count(self, size: int) -> None:
        self.conn.stat_bytes += size
        self.conn.stat_num_msg += 1

    def _close(self) -> None:
        try:
            self.conn.close()  # rospy then drops the connection from the topic
        except Exception:  # a connection already torn down
            pass


def outbox(conn: Any, topic: str) -> Outbox:
    """The outbox of ``conn``, made on first use; it goes when the connection goes."""
    box = _outboxes.get(conn)
    if box is None:
        with _outboxes_lock:
            box = _outboxes.get(conn)
            if box is None:
                box = _outboxes[conn] = Outbox(conn, topic)
    return box


def send_to_all(connections: Any, topic: str, body: bytes) -> None:
    """Send one serialized message body to every connection of ``topic``."""
    _send_parts(connections, topic, (_LENGTH.pack(len(body)), body), len(body) + 4)


def send_framed_to_all(connections: Any, topic: str, framed: memoryview) -> None:
    """Send one serialized message that starts with its length (as rospy's ``serialize_message`` writes it)."""
    _send_parts(connections, topic, (framed,), len(framed))


def _send_parts(connections: Any, topic: str, parts: tuple, size: int) -> None:
    for conn in connections:
        outbox(conn, topic).send(parts, size)


class Frame:
    """One message sent to the connections of ``topic`` in parts, as it arrives (length prefix first).

    The connections are those of the moment it opens: one that connects meanwhile gets the
    next message, whole.
    """

    def __init__(self, connections: Iterable[Any], topic: str, size: int) -> None:
        self.boxes = [outbox(conn, topic) for conn in connections]
        for box in self.boxes:
            box.open(size)

    def part(self, data: memoryview) -> None:
        for box in self.boxes:
            box.part(data)

    def close(self) -> None:
        for box in self.boxes:
            box.close_frame()

    def abort(self) -> None:
        for box in self.boxes:
            box.abort_frame()


def count_dropped(topic: str) -> None:
    """One message of ``topic`` was dropped before it went out."""
    with _counts_lock:
        _dropped[topic] = _dropped.get(topic, 0) + 1


def dropped(topic: str) -> int:
    """Messages dropped on ``topic`` so far because a subscriber could not keep up."""
    return _dropped.get(topic, 0)


def backlog(topic: str) -> Backlog:
    """What waits on ``topic``'s slow connections now, and what was dropped."""
    with _outboxes_lock:
        boxes = [b for b in _outboxes.values() if b.topic == topic and b.waiting]
    return Backlog(len(boxes), sum(b.waiting for b in boxes), dropped(topic))
