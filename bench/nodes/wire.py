"""The bench's messages on the wire: which types, and where the bench's marks sit in their bytes.

Publisher and subscriber of the relay bench work on serialized bytes, not message
objects, so that neither end costs more than the thing being measured (the relay in
between). Every bench message is a ROS message with a ``std_msgs/Header`` first, laid
out as::

    uint32 seq | uint32 stamp.secs | uint32 stamp.nsecs | uint32 len=10 | frame_id (10 digits) | rest

``header.stamp`` is the publisher's wall clock just before the bytes are written (the
subscriber reads its own wall clock on arrival: same machine, same clock), and
``header.frame_id`` is the message's index as ten ASCII digits, so that loss is counted
by index, whatever a relay does to ``header.seq`` (rospy overwrites it with its own
count when it serializes a message object).

The handler relay changes one field per kind (``handle``); ``handled`` tells the
subscriber, from the bytes, whether a message went through that handler.
"""

from __future__ import annotations

import io
import struct
from dataclasses import dataclass
from typing import Any, Callable

STAMP = struct.Struct("<II")
STAMP_AT = 4  # offset of stamp.secs in the serialized message (after seq)
INDEX_AT, INDEX_LEN = 16, 10  # frame_id's characters, after its uint32 length
REST_AT = INDEX_AT + INDEX_LEN


@dataclass(frozen=True)
class Kind:
    """One message kind of the bench: its class, a sample and its handler's one change."""

    name: str
    type_name: str  # ROS type, e.g. "geometry_msgs/TwistStamped"
    make: Callable[[], Any]  # a sample message (frame_id set by template())
    handle: Callable[[Any], None]  # what the handler relay changes, in place
    handled: Callable[[bytes], bool]  # whether serialized bytes carry that change


def _twist():
    from geometry_msgs.msg import TwistStamped

    return TwistStamped()


def _twist_handle(msg) -> None:
    msg.twist.angular.z = 1.0


# TwistStamped after the header: linear x y z, angular x y z, all float64.
_ANGULAR_Z = struct.Struct("<d")
_ANGULAR_Z_AT = REST_AT + 5 * 8


def _twist_handled(buff: bytes) -> bool:
    return _ANGULAR_Z.unpack_from(buff, _ANGULAR_Z_AT)[0] == 1.0


IMAGE_SIDE = 1024  # 1024 x 1024 mono8: 1 MiB of pixels


def _image():
    from sensor_msgs.msg import Image

    side = IMAGE_SIDE
    return Image(height=side, width=side, encoding="mono8", is_bigendian=0, step=side,
                 data=bytes(range(256)) * (side * side // 256))


def _image_handle(msg) -> None:
    # Same pixels, another name for the same encoding: a change a real handler might make.
    msg.encoding = "8UC1"


# Image after the header: uint32 height, uint32 width, string encoding (uint32 length + chars).
_ENCODING_AT = REST_AT + 8


def _image_handled(buff: bytes) -> bool:
    return buff[_ENCODING_AT:_ENCODING_AT + 8] == b"\x04\x00\x00\x008UC1"


KINDS = {
    "twist": Kind("twist", "geometry_msgs/TwistStamped", _twist, _twist_handle, _twist_handled),
    "image": Kind("image", "sensor_msgs/Image", _image, _image_handle, _image_handled),
}


def message_class(kind: str) -> type:
    return type(KINDS[kind].make())


def template(kind: str) -> bytearray:
    """The serialized sample of ``kind``, preceded by its TCPROS 4-byte length, to patch in place."""
    msg = KINDS[kind].make()
    msg.header.frame_id = "0" * INDEX_LEN
    buff = io.BytesIO()
    msg.serialize(buff)
    body = buff.getvalue()
    return bytearray(struct.pack("<I", len(body)) + body)


def stamp(packet: bytearray, index: int, now_ns: int) -> None:
    """Write seq, stamp and index into a template (offsets shifted by its 4-byte length)."""
    secs, nsecs = divmod(now_ns, 1_000_000_000)
    struct.pack_into("<III", packet, 4, index + 1, secs, nsecs)
    packet[4 + INDEX_AT:4 + REST_AT] = b"%010d" % index


def read_stamp(buff: bytes) -> tuple[int, int]:
    """(index, stamp in ns) of one serialized message (without the length prefix)."""
    secs, nsecs = STAMP.unpack_from(buff, STAMP_AT)
    return int(buff[INDEX_AT:REST_AT]), secs * 1_000_000_000 + nsecs
