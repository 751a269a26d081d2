"""A relay written with rospy alone, in every variant the bench compares to find the fastest.

    rospy_relay.py IN OUT KIND [options]

``--mode reuse`` forwards the bytes it receives (rospy.AnyMsg) unchanged; ``--mode
handler`` deserializes into the concrete class, lets the kind's handler change one
field and publishes the object. The other options are the knobs that matter to a
relay; ``python -m bench.relay --recipes`` runs them side by side. The defaults are the
winning recipe (see bench/README.md), so that this file is also its reference code.
"""

from __future__ import annotations

import argparse
import ctypes
import io
import struct

import nodeio
import rospy
import wire
from rospy.msg import serialize_message

_LENGTH = struct.Struct("<I")

# rospy reads a socket with sock.recv(buff_size), and CPython allocates buff_size (+33)
# bytes for each call. From 128 KiB on, glibc serves that with mmap/munmap: about 15 µs
# per read, per message when messages are small. Just under it costs ~1.5 µs, and reads
# a 1 MiB image in 8 calls (faster per MiB than 64 KiB reads, rospy's default, or 4 MiB).
READ_SIZE = 127 * 1024


def queue_arg(text: str):
    """``none`` (rospy's None: unbounded subscriber queue, synchronous publisher) or a size."""
    return None if text == "none" else int(text)


def parse(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("source")
    parser.add_argument("target")
    parser.add_argument("kind", choices=sorted(wire.KINDS))
    parser.add_argument("--mode", choices=["reuse", "handler"], default="reuse")
    parser.add_argument("--sub-queue", type=queue_arg, default=None)
    parser.add_argument("--buff-size", type=int, default=READ_SIZE)
    parser.add_argument("--sub-nodelay", type=int, choices=[0, 1], default=1)
    parser.add_argument("--pub-queue", type=queue_arg, default=None)
    parser.add_argument("--write", choices=["sendmsg", "impl", "joined"], default="sendmsg",
                        help="reuse: length and bytes in one sendmsg per connection (no copy); "
                             "impl.publish(raw); or length + bytes joined, then write_data")
    parser.add_argument("--typed-write", choices=["publish", "buffer"], default="publish",
                        help="handler: Publisher.publish; or serialize into a kept buffer and sendmsg a view of it")
    parser.add_argument("--advertise", choices=["eager", "lazy"], default="eager",
                        help="advertise OUT at start-up, or when the first message arrives")
    parser.add_argument("--mallopt", action="store_true",
                        help="keep big allocations on glibc's heap (no mmap/munmap and page faults per image)")
    return parser.parse_args(argv)


def send_all(impl, parts, size: int) -> None:
    """Write one serialized message (``parts``: length prefix and body) to every connection.

    Call with the impl's lock held: two threads writing one socket would interleave.
    A connection that fails is closed, which makes rospy drop it from the topic, as
    its own publish does.
    """
    for conn in impl.connections:
        sock = conn.socket
        if sock is None or conn.done:
            continue
        try:
            sent = sock.sendmsg(parts)
            if sent < size:  # a signal cut the call short: send the rest
                sock.sendall(b"".join(parts)[sent:])
            conn.stat_bytes += size
            conn.stat_num_msg += 1
        except OSError:
            conn.close()


class Relay:
    """Subscribes to source and publishes on target, as the options say."""

    def __init__(self, opts: argparse.Namespace) -> None:
        self.opts = opts
        self.cls = wire.message_class(opts.kind)
        self.handle = wire.KINDS[opts.kind].handle
        self.pub = self.impl = None
        self.header_seen = None  # the connection header whose latching was last looked at
        self.buffer = io.BytesIO()  # kept: re-growing 1 MiB each message costs page faults
        if opts.advertise == "eager":
            self.advertise(latch=False)
        if opts.mode == "reuse":
            callback = {"sendmsg": self.forward, "impl": self.forward_impl, "joined": self.forward_joined}[opts.write]
        else:
            callback = self.on_message
        rospy.Subscriber(opts.source, rospy.AnyMsg if opts.mode == "reuse" else self.cls, callback,
                         queue_size=opts.sub_queue, buff_size=opts.buff_size,
                         tcp_nodelay=bool(opts.sub_nodelay))

    def advertise(self, latch: bool) -> None:
        self.pub = rospy.Publisher(self.opts.target, self.cls, queue_size=self.opts.pub_queue, latch=latch)
        self.impl = self.pub.impl

    def target(self, msg):
        """The publisher impl to write ``msg`` to, latching as the source does."""
        if msg._connection_header is not self.header_seen:  # an identity test, not a dict lookup
            self.follow_latching(msg)
        return self.impl

    def follow_latching(self, msg) -> None:
        """A new connection's first message says whether the source latches; the target follows."""
        self.header_seen = msg._connection_header
        latched = self.header_seen.get("latching") == "1"
        if self.impl is None:
            self.advertise(latch=latched)
        elif latched and not self.impl.is_latch:
            self.impl.enable_latch()

    def forward(self, raw: rospy.AnyMsg) -> None:
        impl = self.target(raw)
        buff = raw._buff
        impl.acquire()
        try:
            if impl.is_latch:
                impl.latch = raw  # rospy sends it to later subscribers (AnyMsg serializes as is)
            send_all(impl, (_LENGTH.pack(len(buff)), buff), 4 + len(buff))
        finally:
            impl.release()

    def forward_impl(self, raw: rospy.AnyMsg) -> None:
        impl = self.target(raw)
        # Publisher.publish would refuse an AnyMsg (it checks the class); the impl
        # serializes whatever it is given, and AnyMsg serializes as its raw bytes.
        impl.acquire()
        try:
            impl.publish(raw)
        finally:
            impl.release()

    def forward_joined(self, raw: rospy.AnyMsg) -> None:
        impl = self.target(raw)
        buff = raw._buff
        packet = _LENGTH.pack(len(buff)) + buff
        impl.acquire()
        try:
            if impl.is_latch:
                impl.latch = raw
            for conn in impl.connections:
                try:
                    conn.write_data(packet)
                except Exception:  # a dead subscriber: rospy's publish would drop it the same way
                    pass
        finally:
            impl.release()

    def on_message(self, msg) -> None:
        self.target(msg)
        self.handle(msg)
        if self.opts.typed_write == "publish":
            self.pub.publish(msg)
        else:
            self.write_typed(msg)

    def write_typed(self, msg) -> None:
        """Publisher.publish without its per-message buffer: serialize into a kept BytesIO."""
        impl = self.impl
        impl.acquire()
        try:
            if impl.is_latch:
                impl.latch = msg
            if not impl.connections:
                return
            b = self.buffer
            b.seek(0)  # no truncate: it would free the buffer, and the next message re-grow it
            impl.seq += 1
            serialize_message(b, impl.seq, msg)  # length prefix, then the message; sets header.seq
            end = b.tell()
            with b.getbuffer() as whole, whole[:end] as view:
                send_all(impl, (view,), end)
        finally:
            impl.release()


def keep_big_allocations_on_heap() -> None:
    """glibc: serve allocations up to 64 MiB from the heap and keep freed memory.

    Without this, every 1 MiB buffer rospy allocates for a message is a fresh mmap whose
    pages fault in one by one (costly in a VM) and are unmapped again on free.
    """
    libc = ctypes.CDLL(None)
    m_trim_threshold, m_mmap_threshold = -1, -3
    libc.mallopt(m_mmap_threshold, 64 << 20)
    libc.mallopt(m_trim_threshold, 256 << 20)


def main(argv=None) -> None:
    opts = parse(argv)
    if opts.mallopt:
        keep_big_allocations_on_heap()
    nodeio.start("bench_relay")
    Relay(opts)
    nodeio.say("ready", opts.source)
    nodeio.serve()


if __name__ == "__main__":
    main()
