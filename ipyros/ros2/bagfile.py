"""ROS 2 bags (a folder: MCAP or sqlite3 storage, CDR messages), through rosbags, a pure-Python bag library.

Recording writes the messages' CDR bytes, to MCAP by default (rosbag2's own default since Iron),
to sqlite3 on request; playing is ``bag_player.py`` (next to this file: rclpy and rosbags), run as
a basenode and remapped with ``--ros-args`` like any other. It plays a rosbag2 folder of either
storage, a bare ``.mcap`` file and a ROS 1 ``.bag``. rosbag2 itself is not on PyPI; rosbags reads
and writes the same files.
"""

from __future__ import annotations

import queue
import threading
import time
from pathlib import Path
from typing import Any, Callable, Collection, Iterator, Optional

from ..core.errors import DeclarationError, first_line
from ..core.msgtypes import type_name
from ..core.records import BagInfo, BagTopic

__all__ = ["PLAYER", "STORAGES", "BagWriter", "bag_info", "bag_messages", "bag_topics"]

#: The storages a recording may be written in; the first is the default.
STORAGES = ("mcap", "sqlite3")

#: The player run as ``baseBag``'s basenode on ROS 2 (ipyros runs it with its own Python).
PLAYER = Path(__file__).resolve().parent / "bag_player.py"


def _rosbags() -> Any:
    try:
        import rosbags.rosbag2
    except ImportError:
        raise DeclarationError("ROS 2 bags need rosbags: pip install rosbags (bash run.sh installs it)") from None
    return rosbags.rosbag2


def _opened(path: Path) -> Any:
    """rosbags' reader of the bag ``path``, open: a rosbag2 folder (MCAP or sqlite3), a bare ``.mcap``
    file, or a ROS 1 ``.bag`` file (which the player turns into ROS 2 messages)."""
    rosbag2 = _rosbags()
    try:
        if path.suffix == ".bag":
            from rosbags.rosbag1 import Reader as Ros1Reader

            reader = Ros1Reader(path)
        else:
            reader = rosbag2.Reader(path)
        reader.open()
    except Exception as error:  # noqa: BLE001 - rosbags' errors of any kind: not a bag we can read
        raise DeclarationError(f"cannot read the bag {path}: {first_line(error)}") from None
    return reader


def bag_topics(path: Path) -> dict[str, str]:
    """The topics recorded in the bag ``path``, with their types; a one-line error if it is no bag."""
    reader = _opened(path)
    try:
        return {c.topic: c.msgtype for c in reader.connections}
    finally:
        reader.close()


def bag_info(path: Path) -> BagInfo:
    """What the bag ``path`` holds: topics, types, counts, start and end (as ``ros2 bag info``)."""
    reader = _opened(path)
    try:
        counts: dict[tuple[str, str], int] = {}
        for c in reader.connections:
            counts[(c.topic, c.msgtype)] = counts.get((c.topic, c.msgtype), 0) + c.msgcount
        storage = {".bag": "bag", ".mcap": "mcap"}.get(path.suffix) or \
            ("mcap" if any(path.glob("*.mcap")) else "sqlite3")  # a rosbag2 folder: its files say which
        empty = not any(counts.values())
        return BagInfo(str(path), storage, 0.0 if empty else reader.start_time / 1e9,
                       0.0 if empty else reader.end_time / 1e9,
                       tuple(BagTopic(topic, msgtype, count) for (topic, msgtype), count in sorted(counts.items())))
    finally:
        reader.close()


def bag_messages(path: Path, topics: Collection[str],
                 counted: Optional[Callable[[int], None]] = None) -> Iterator[tuple[str, int, Any]]:
    """``(topic, stamp in ns, message)`` of each message of ``topics`` in the bag, in recorded order, as this
    Python's message classes (a ROS 1 ``.bag``'s turned into ROS 2 messages, as the player turns them).
    ``counted(n)`` hears how many there are as the bag opens."""
    from rclpy.serialization import deserialize_message

    from .bag_player import Ros1Bag, message_class

    if path.suffix == ".bag":
        _rosbags()
        reader: Any = Ros1Bag(str(path))
        try:
            reader.open()
        except Exception as error:  # noqa: BLE001 - rosbags' errors of any kind: not a bag we can read
            raise DeclarationError(f"cannot read the bag {path}: {first_line(error)}") from None
    else:
        reader = _opened(path)
    try:
        connections = [c for c in reader.connections if c.topic in topics]
        classes = {c.id: message_class(c.msgtype) for c in connections}
        if counted is not None:
            counted(sum(getattr(c, "msgcount", 0) for c in connections))
        for connection, stamp, raw in reader.messages(connections=connections):
            yield connection.topic, stamp, deserialize_message(bytes(raw), classes[connection.id])
    finally:
        reader.close()


class BagWriter:
    """Messages written to a new bag folder (``storage``: mcap, the default, or sqlite3), stamped with the wall
    clock on arrival.

    rosbags' sqlite3 storage may only be used from the thread that opened it: one writer
    thread of its own opens, writes and closes the bag; handlers only queue the bytes
    (so recording never slows a node down either).
    """

    def __init__(self, path: Path, storage: Optional[str] = None) -> None:
        _rosbags()
        if storage is not None and storage not in STORAGES:
            raise DeclarationError(f"storage={storage!r}: a ROS 2 bag is written in {' or '.join(STORAGES)}")
        self.path, self.storage = path, storage or STORAGES[0]
        self.count = 0
        self._queue: "queue.SimpleQueue[Optional[tuple[str, str, bytes, int]]]" = queue.SimpleQueue()
        opened: "queue.SimpleQueue[Optional[BaseException]]" = queue.SimpleQueue()
        self._thread = threading.Thread(target=self._write_all, args=(opened,), name="ipyros-bag", daemon=True)
        self._thread.start()
        problem = opened.get()
        if problem is not None:
            raise DeclarationError(f"cannot write the bag {path}: {problem}") from None
        self._closed = False

    def _write_all(self, opened: "queue.SimpleQueue[Optional[BaseException]]") -> None:
        from rosbags.rosbag2 import StoragePlugin, Writer
        from rosbags.typesys import Stores, get_typestore

        typestore = get_typestore(Stores.ROS2_JAZZY)  # the common message types, for the bag's metadata
        try:
            bag = Writer(self.path, version=9, storage_plugin=StoragePlugin[self.storage.upper()])
            bag.open()
        except Exception as error:  # noqa: BLE001 - rosbags' errors: said by the constructor
            opened.put(error)
            return
        opened.put(None)
        connections: dict[str, Any] = {}
        try:
            while (item := self._queue.get()) is not None:
                topic, msgtype, data, stamp = item
                connection = connections.get(topic)
                if connection is None:
                    known = msgtype in typestore.types
                    connection = connections[topic] = bag.add_connection(
                        topic, msgtype, typestore=typestore if known else None,
                        msgdef=None if known else "", rihs01=None if known else "RIHS01_" + "0" * 64)
                bag.write(connection, stamp, data)
        finally:
            bag.close()

    def write(self, topic: str, msg: Any, stamp: Optional[int] = None) -> None:
        """Write ``msg`` stamped ``stamp`` (ns; default: the wall clock now)."""
        from rclpy.serialization import serialize_message

        if self._closed:
            return
        package, name = (type_name(type(msg)) or "?/?").split("/")
        self._queue.put((topic, f"{package}/msg/{name}", serialize_message(msg),
                         time.time_ns() if stamp is None else stamp))
        self.count += 1

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self._queue.put(None)
            self._thread.join(timeout=30)
