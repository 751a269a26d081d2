"""Reading a large message straight into one buffer, and relaying it while it still arrives (cut-through).

rospy reads a message in ``buff_size`` pieces (127 KiB here, :mod:`.endpoints`), each a new
bytes object appended to a growing buffer, and copies the message out once it is whole:
three copies of a 1 MiB image, each into fresh memory, before a handler parses it or a
relay sends it on; and a relay's hop starts only once the first hop has ended.

This module takes over, on the connections of every subscription of the session, the step
where rospy looks for a whole message in what it has read (the protocol's ``read_messages``,
which rospy lets read more from the socket itself): once a message's length says it is
large, the rest of it is read straight from the socket into one buffer of its size. When a
relay reads the topic (:attr:`Reading.sink`), each piece also goes on to the relay's
subscribers as it lands (:class:`~.sending.Frame`), so both hops run together; the relay
then only counts and latches the whole message, which the topic's other readers (a handler,
``%echo``) are handed as before.

Only a relay fed by one publisher connection (the wrapped basenode) sends pieces: pieces of
two incoming messages must never mix on an outgoing stream, so while one message goes out
in pieces, a message from another connection waits for it and goes whole. If the incoming
connection breaks in the middle, the subscribers' streams are cut: the relay closes their
connections and has them connect again (:meth:`~.endpoints.Relay.abort`).
"""

from __future__ import annotations

import struct
from typing import Any, Optional, Protocol

from rospy.exceptions import TransportTerminated

from . import rospy_inside
from .sending import Frame

__all__ = ["LARGE_BYTES", "FrameSink", "Reading", "reading"]

#: Messages from this size (length prefix included) are read this way; a smaller one mostly
#: comes in one read, and its time is in the per-message work, not in copies.
LARGE_BYTES = 256 * 1024
_LENGTH = struct.Struct("<I")


class FrameSink(Protocol):
    """What a relay offers to the connections of its source topic."""

    def begin(self, header: dict, size: int) -> Optional[Frame]:
        """A frame to send a message of ``size`` bytes in pieces, or None (then it is sent whole)."""

    def end(self, frame: Frame, message: Any) -> None:
        """``frame`` was sent in full; ``message`` is the whole message the readers will be handed."""

    def abort(self, frame: Frame) -> None:
        """``frame`` will never be whole."""


class Reading:
    """How one subscription (a rospy ``_SubscriberImpl``) reads large messages; ``sink`` is the relay
    that sends them on as they arrive, if any (one per topic: a second relay of it sends whole messages)."""

    def __init__(self, sub_impl: Any) -> None:
        self.sub_impl = sub_impl
        self.sink: Optional[FrameSink] = None

    def read_messages(self, conn: Any, read_whole: Any, b: Any, msg_queue: list, sock: Any) -> None:
        """rospy's step after each read, for ``conn``: the bytes read since its last whole message are at
        the start of ``b``; ``read_whole`` is rospy's own step."""
        read_whole(b, msg_queue, sock)  # whole messages first: small ones pay nothing more
        have = b.tell()
        if msg_queue or have < 4:
            return
        with b.getbuffer() as view:
            (length,) = _LENGTH.unpack_from(view, 0)
        if LARGE_BYTES <= length + 4 and have < length + 4:
            sink = self.sink
            frame = sink.begin(conn.header, length + 4) if sink is not None else None
            msg_queue.append(self._read_rest(conn, b, have, length, sock, sink, frame))

    def _read_rest(self, conn: Any, b: Any, have: int, length: int, sock: Any,
                   sink: Optional[FrameSink], frame: Optional[Frame]) -> Any:
        """The message, its rest read into its own buffer; each piece sent on as it lands when ``frame``."""
        body = bytearray(length)
        into = memoryview(body)
        try:
            with b.getbuffer() as view:
                if frame is not None:
                    _send(frame, view[:have])
                into[:have - 4] = view[4:have]
            b.seek(0)
            b.truncate(0)
            at = have - 4
            while at < length:
                got = sock.recv_into(into[at:])
                if not got:
                    raise TransportTerminated("unable to receive data from sender, check sender's logs for details")
                if frame is not None:
                    _send(frame, into[at:at + got])
                at += got
        except BaseException:
            if frame is not None:
                sink.abort(frame)
            raise
        finally:
            into.release()
        conn.stat_bytes += length + 4 - have  # rospy counts only what it reads itself
        message = conn.protocol.recv_data_class()
        # A relay alone on the topic only sends the buffer on (or latches it); other readers parse bytes.
        alone = sink is not None and len(self.sub_impl.callbacks) == 1
        message._buff = body if alone else bytes(body)
        if frame is not None:
            sink.end(frame, message)
        return message


def reading(sub_impl: Any) -> Reading:
    """The :class:`Reading` of ``sub_impl``, set up on its connections (now and later) on first call."""
    found = sub_impl.__dict__.get("_ipyros_reading")
    if found is not None:
        return found
    found = sub_impl._ipyros_reading = Reading(sub_impl)
    rospy_inside.on_connection_added(sub_impl, lambda conn: rospy_inside.take_over_reading(conn, found.read_messages))
    return found


def _send(frame: Frame, piece: memoryview) -> None:
    try:
        frame.part(piece)
    finally:
        piece.release()
