"""The ROS 2 bench's messages as CDR bytes, and where its marks sit in them.

As in the ROS 1 bench (``bench/nodes/wire.py``), publisher and subscriber work on
serialized bytes, so that neither costs more than the relay in between. Every message
starts with a ``std_msgs/Header``; in CDR (after the 4-byte encapsulation header)::

    int32 stamp.sec | uint32 stamp.nanosec | uint32 len=11 | frame_id (10 digits + NUL) | rest

``header.stamp`` is the publisher's wall clock just before publishing, ``frame_id`` the
message's index, so loss is counted by index whatever a relay does.
"""

from __future__ import annotations

import struct
from typing import Any, Callable

STAMP = struct.Struct("<iI")
STAMP_AT = 4
INDEX_AT, INDEX_LEN = 16, 10


def _twist() -> Any:
    from geometry_msgs.msg import TwistStamped

    return TwistStamped()


def _image(rows: int = 512) -> Callable[[], Any]:
    """Images of 512 x rows RGBA pixels: 2 KiB a row, so 512 rows make 1 MiB."""
    def sample() -> Any:
        from sensor_msgs.msg import Image

        msg = Image(height=rows, width=512, encoding="rgba8", step=2048)
        msg.data = bytes(rows * 2048)
        return msg

    return sample


def _twist_handle(msg: Any) -> None:
    msg.twist.angular.z = 1.0


def _image_handle(msg: Any) -> None:
    msg.is_bigendian = 1


def _image_kind(rows: int) -> tuple[str, Callable[[], Any], Callable[[Any], None], Callable[[Any], bool]]:
    return "sensor_msgs/msg/Image", _image(rows), _image_handle, lambda m: m.is_bigendian == 1


KINDS: dict[str, tuple[str, Callable[[], Any], Callable[[Any], None], Callable[[Any], bool]]] = {
    # kind: (type, a sample, the handler's one change, whether a message carries it)
    "twist": ("geometry_msgs/msg/TwistStamped", _twist, _twist_handle, lambda m: m.twist.angular.z == 1.0),
    "image": _image_kind(512),  # 1 MiB, a camera's
    "image256k": _image_kind(128),
    "image4m": _image_kind(2048),
    "image16m": _image_kind(8192),  # a point cloud's size
}


def message_class(kind: str) -> type:
    return type(KINDS[kind][1]())


def template(kind: str) -> bytearray:
    """A serialized sample whose stamp and index the publisher overwrites in place."""
    from rclpy.serialization import serialize_message

    msg = KINDS[kind][1]()
    msg.header.frame_id = "0" * INDEX_LEN
    return bytearray(serialize_message(msg))


def mark(buff: bytearray, index: int, now: float) -> None:
    secs = int(now)
    STAMP.pack_into(buff, STAMP_AT, secs, int((now - secs) * 1e9))
    buff[INDEX_AT:INDEX_AT + INDEX_LEN] = b"%010d" % index


def read(buff: bytes) -> tuple[int, float]:
    """The index and the publisher's stamp of a serialized message."""
    secs, nsecs = STAMP.unpack_from(buff, STAMP_AT)
    return int(buff[INDEX_AT:INDEX_AT + INDEX_LEN]), secs + nsecs * 1e-9
