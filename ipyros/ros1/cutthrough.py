"""Relaying a large message while it still arrives (cut-through), read straight into one buffer.

rospy reads a message in ``buff_size`` pieces (127 KiB here, :mod:`.runtime`), each a new
bytes object appended to a growing buffer, and copies the message out once it is whole; a
relay then sends it on. For a 1 MiB image that is three copies and fresh memory for each
in the relay, and the relay's hop starts only once the first hop has ended.

This module takes over, on the connections of a relayed topic, the step where rospy looks
for a whole message in what it has read (the protocol's ``read_messages``, which rospy lets
read more from the socket itself): once a message's length says it is large, the rest of it
is read straight from the socket into one buffer of its size, and each piece is sent on to
the relay's subscribers as it lands (:class:`~.sending.Frame`). The whole message is still
handed to the topic's readers as before (the relay only counts and latches it; a handler or
``%echo`` on the same topic parse it).

It applies to a relay fed by one publisher connection (the wrapped basenode): pieces of
two incoming messages must never mix on an outgoing stream, so while one message is sent
in pieces, a message from another connection waits for it and goes whole. If the incoming
connection breaks in the middle, the subscribers' streams are cut: their connections are
closed, and they connect again (rospy and roscpp subscribers do) and get the next message whole.
"""

from __future__ import annotations

import struct
from typing import Any, Callable, Optional, Protocol

from rospy.exceptions import TransportTerminated

from .sending import Frame

__all__ = ["CUT_THROUGH_BYTES", "FrameSink", "install"]

#: Messages from this size (length prefix included) are read and sent on this way; a smaller
#: one mostly comes in one read, and its time is in the per-message work, not in copies.
CUT_THROUGH_BYTES = 256 * 1024
_LENGTH = struct.Struct("<I")


class FrameSink(Protocol):
    """What a relay offers to the connections of its source topic."""

    def begin(self, header: dict, size: int) -> Optional[Frame]:
        """A frame to send a message of ``size`` bytes in pieces, or None (then it is sent whole)."""

    def end(self, frame: Frame, message: Any) -> None:
        """``frame`` was sent in full; ``message`` is the whole message the readers will be handed."""

    def abort(self, frame: Frame) -> None:
        """``frame`` will never be whole."""


def install(sub_impl: Any, sink: FrameSink) -> Callable[[], None]:
    """Read large messages of ``sub_impl``'s connections (now and later) through to ``sink``.

    Returns what takes it away again. One sink per topic: a second relay of the same source
    sends whole messages.
    """
    if "_ipyros_cut_through" in sub_impl.__dict__:
        return lambda: None
    sub_impl._ipyros_cut_through = sink
    add_connection = sub_impl.add_connection

    def add_and_watch(conn: Any) -> bool:
        _Reader.watch(conn, sub_impl, sink)
        return add_connection(conn)

    sub_impl.add_connection = add_and_watch
    for conn in list(sub_impl.connections):
        _Reader.watch(conn, sub_impl, sink)

    def remove() -> None:
        sub_impl.__dict__.pop("add_connection", None)
        sub_impl.__dict__.pop("_ipyros_cut_through", None)
        for conn in list(sub_impl.connections):
            conn.protocol.__dict__.pop("read_messages", None)

    return remove


class _Reader:
    """Stands in for one connection's ``protocol.read_messages``; rospy calls it after each read, with
    the bytes read since the last whole message at the start of ``b``."""

    def __init__(self, conn: Any, sub_impl: Any, sink: FrameSink) -> None:
        self.conn, self.sub_impl, self.sink = conn, sub_impl, sink
        self.read_whole = conn.protocol.read_messages

    @classmethod
    def watch(cls, conn: Any, sub_impl: Any, sink: FrameSink) -> None:
        if "read_messages" not in conn.protocol.__dict__:
            conn.protocol.read_messages = cls(conn, sub_impl, sink).read_messages

    def read_messages(self, b: Any, msg_queue: list, sock: Any) -> None:
        have = b.tell()
        if have >= 4:
            with b.getbuffer() as view:
                (length,) = _LENGTH.unpack_from(view, 0)
            if CUT_THROUGH_BYTES <= length + 4 and have < length + 4:
                frame = self.sink.begin(self.conn.header, length + 4)
                if frame is not None:
                    msg_queue.append(self._read_through(b, have, length, sock, frame))
                    return
        self.read_whole(b, msg_queue, sock)

    def _read_through(self, b: Any, have: int, length: int, sock: Any, frame: Frame) -> Any:
        """The rest of the message read into its own buffer, each piece sent on as it lands."""
        body = bytearray(length)
        into = memoryview(body)
        try:
            with b.getbuffer() as view:
                _send(frame, view[:have])
                into[:have - 4] = view[4:have]
            b.seek(0)
            b.truncate(0)
            at = have - 4
            while at < length:
                got = sock.recv_into(into[at:])
                if not got:
                    raise TransportTerminated("unable to receive data from sender, check sender's logs for details")
                _send(frame, into[at:at + got])
                at += got
        except BaseException:
            self.sink.abort(frame)
            raise
        finally:
            into.release()
        self.conn.stat_bytes += length + 4 - have  # rospy counts only what it reads itself
        message = self.conn.protocol.recv_data_class()
        # The relay alone reads this topic: it only sends the buffer on (or latches it); others parse bytes.
        message._buff = body if len(self.sub_impl.callbacks) == 1 else bytes(body)
        self.sink.end(frame, message)
        return message


def _send(frame: Frame, piece: memoryview) -> None:
    try:
        frame.part(piece)
    finally:
        piece.release()
