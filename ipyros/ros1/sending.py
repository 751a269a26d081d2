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
  for that connection queue behind it (order is kept), so the caller never waits.
  The backlog holds at most ``limit`` messages (and ``limit_bytes``): when full, the
  oldest message not yet begun is dropped and counted, as ROS users know from
  ``queue_size``. A message that has begun to go out is never dropped: the stream would
  be cut in the middle of a frame.

Counts are kept per topic (:func:`dropped`, :func:`backlog`), for ``%status``.
"""

from __future__ import annotations

import socket
import struct
import threading
import weakref
from collections import deque
from dataclasses import dataclass
from typing import Any

#: Messages a slow connection may have waiting before its oldest are dropped.
LIMIT = 100
#: Bytes a slow connection may have waiting (1 MiB images: 32 of them).
LIMIT_BYTES = 32 * 1024 * 1024

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


class Outbox:
    """The sending side of one subscriber connection (a rospy ``TCPROSTransport``)."""

    def __init__(self, conn: Any, topic: str, limit: int = LIMIT, limit_bytes: int = LIMIT_BYTES) -> None:
        self.conn, self.topic = conn, topic
        self.limit, self.limit_bytes = limit, limit_bytes
        self._waiting: deque[memoryview] = deque()  # the head may be partly sent already
        self._head_started = False
        self._bytes = 0
        self._lock = threading.Lock()
        self._wake = threading.Condition(self._lock)
        self._writer: threading.Thread | None = None

    @property
    def waiting(self) -> int:
        return len(self._waiting)

    def send(self, parts: tuple[bytes, ...], size: int) -> None:
        """Send one length-prefixed message (``parts`` joined are ``size`` bytes); never blocks."""
        sock = getattr(self.conn, "socket", None)
        if sock is None or getattr(self.conn, "done", False):
            return
        with self._lock:
            if not self._waiting:
                try:
                    sent = sock.sendmsg(parts, (), socket.MSG_DONTWAIT)
                except BlockingIOError:
                    sent = 0
                except OSError:
                    self._close()
                    return
                if sent == size:
                    self._count(size)
                    return
                rest = memoryview(b"".join(parts))[sent:]
                self._head_started = sent > 0
                self._push(rest)
            else:
                self._push(memoryview(b"".join(parts)))
            self._start_writer()
            self._wake.notify()

    def _push(self, data: memoryview) -> None:
        self._waiting.append(data)
        self._bytes += len(data)
        while len(self._waiting) > self.limit or self._bytes > self.limit_bytes:
            first = 1 if self._head_started else 0  # a begun head must go out whole
            if len(self._waiting) - first <= 1:
                break  # the newest message always stays
            dropped = self._waiting[first]
            del self._waiting[first]
            self._bytes -= len(dropped)
            with _counts_lock:
                _dropped[self.topic] = _dropped.get(self.topic, 0) + 1

    def _start_writer(self) -> None:
        if self._writer is None or not self._writer.is_alive():
            self._writer = threading.Thread(target=self._drain, name=f"ipyros-outbox {self.topic}", daemon=True)
            self._writer.start()

    def _drain(self) -> None:
        """The writer thread: blocking sends of the backlog, head first, until it is empty."""
        sock = self.conn.socket
        while True:
            with self._lock:
                if not self._waiting:
                    self._writer = None
                    return
                head = self._waiting[0]
            try:
                sent = sock.send(head)  # blocks until the peer reads: only this thread waits
            except OSError:
                with self._lock:
                    self._waiting.clear()
                    self._bytes = 0
                    self._writer = None
                self._close()
                return
            with self._lock:
                if sent == len(head):
                    self._waiting.popleft()
                    self._bytes -= len(head)
                    self._head_started = False
                    self._count(0)
                else:
                    self._waiting[0] = head[sent:]
                    self._bytes -= sent
                    self._head_started = True

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
    parts = (_LENGTH.pack(len(body)), body)
    size = len(body) + 4
    for conn in connections:
        outbox(conn, topic).send(parts, size)


def dropped(topic: str) -> int:
    """Messages dropped on ``topic`` so far because a subscriber could not keep up."""
    return _dropped.get(topic, 0)


def backlog(topic: str) -> Backlog:
    """What waits on ``topic``'s slow connections now, and what was dropped."""
    with _outboxes_lock:
        boxes = [b for b in _outboxes.values() if b.topic == topic and b.waiting]
    return Backlog(len(boxes), sum(b.waiting for b in boxes), dropped(topic))
