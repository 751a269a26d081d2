"""ROS 1 bag files, through Debian's ``python3-rosbag``: what a bag holds, writing one, playing one. A path ending in
``.mcap`` is an MCAP file of ROS 1 messages instead (:mod:`.mcapfile`).

Playing is ``bag_player.py`` (next to this file: rospy and python3-rosbag, like ``rosbag
play`` but under the node name it is given), run as a basenode: remapped like any other,
so that a wrapping node sits on the topics it plays.
"""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Any, Callable, Collection, Iterator, Optional

from ..core.errors import DeclarationError, first_line
from ..core.records import BagInfo, BagTopic
from . import mcapfile

__all__ = ["PLAYER", "STORAGES", "BagWriter", "RosbagWriter", "bag_info", "bag_messages", "bag_topics"]

#: The storages a recording may be written in: a ROS 1 bag file, or an MCAP file of ROS 1 messages.
STORAGES = ("bag", "mcap")

#: The player run as ``baseBag``'s basenode (a .py file: ipyros runs it with its own Python).
PLAYER = Path(__file__).resolve().parent / "bag_player.py"


def _rosbag() -> Any:
    try:
        import rosbag
    except ImportError:
        raise DeclarationError("ROS 1 bags need Debian's python3-rosbag: apt-get install python3-rosbag "
                               "(bash run.sh installs it)") from None
    return rosbag


def _unreadable(path: Path, error: Exception) -> DeclarationError:
    return DeclarationError(f"cannot read the bag {path}: {first_line(error)}; is it a ROS 1 bag (rosbag record, "
                            "%record)?")


def bag_topics(path: Path) -> dict[str, str]:
    """The topics recorded in the bag at ``path``, with their types; a one-line error if it is no bag."""
    if path.suffix == ".mcap":
        return mcapfile.mcap_topics(path)
    rosbag = _rosbag()
    try:
        with rosbag.Bag(str(path)) as bag:
            return {topic: info.msg_type for topic, info in bag.get_type_and_topic_info().topics.items()}
    except Exception as error:  # noqa: BLE001 - rosbag's errors of any kind (a garbage file: UnicodeDecodeError)
        raise _unreadable(path, error) from None


def bag_info(path: Path) -> BagInfo:
    """What the bag at ``path`` holds: topics, types, counts, start and end (as ``rosbag info``)."""
    if path.suffix == ".mcap":
        return mcapfile.mcap_info(path)
    rosbag = _rosbag()
    try:
        with rosbag.Bag(str(path)) as bag:
            topics = bag.get_type_and_topic_info().topics
            rows = tuple(BagTopic(topic, info.msg_type, info.message_count) for topic, info in sorted(topics.items()))
            empty = not any(row.count for row in rows)
            return BagInfo(str(path), "bag", 0.0 if empty else bag.get_start_time(),
                           0.0 if empty else bag.get_end_time(), rows)
    except Exception as error:  # noqa: BLE001 - rosbag's errors of any kind (a garbage file: UnicodeDecodeError)
        raise _unreadable(path, error) from None


def bag_messages(path: Path, topics: Collection[str],
                 counted: Optional[Callable[[int], None]] = None) -> Iterator[tuple[str, int, Any]]:
    """``(topic, stamp in ns, message)`` of each message of ``topics`` in the bag, in recorded order (the
    messages of the types the bag recorded, as rosbag reads them). ``counted(n)`` hears how many there are as the
    bag opens, from its index (reading it once more would cost a fifth of a second a 100,000 messages)."""
    if path.suffix == ".mcap":
        yield from mcapfile.mcap_messages(path, topics)
        return
    rosbag = _rosbag()
    try:
        bag = rosbag.Bag(str(path))
    except Exception as error:  # noqa: BLE001 - rosbag's errors of any kind
        raise _unreadable(path, error) from None
    with bag:
        if counted is not None:
            counted(bag.get_message_count(topic_filters=list(topics)))
        for topic, msg, stamp in bag.read_messages(topics=list(topics)):
            yield topic, stamp.to_nsec(), msg


def BagWriter(path: Path, storage: Optional[str] = None) -> Any:  # noqa: N802 - a class to its callers
    """A writer of a new bag at ``path``: a ROS 1 bag, or an MCAP file when ``path`` ends in ``.mcap``."""
    if storage not in (None, *STORAGES):
        raise DeclarationError(f"storage={storage!r}: a ROS 1 recording is a .bag file or an .mcap file (sqlite3 "
                               "is ROS 2's)")
    if storage == "mcap" and path.suffix != ".mcap":
        raise DeclarationError(f"{path}: an MCAP recording is a file ending in .mcap; name it {path.stem}.mcap")
    return mcapfile.McapWriter(path) if path.suffix == ".mcap" else RosbagWriter(path)


class RosbagWriter:
    """Messages written to a new ROS 1 bag, from any thread, stamped with the wall clock on arrival."""


    def __init__(self, path: Path) -> None:
        rosbag = _rosbag()
        try:
            self._bag = rosbag.Bag(str(path), "w")
        except (OSError, rosbag.ROSBagException) as error:
            raise DeclarationError(f"cannot write the bag {path}: {error}") from None
        self._lock = threading.Lock()
        self.count = 0

    def write(self, topic: str, msg: Any, stamp: Optional[int] = None) -> None:
        """Write ``msg`` stamped ``stamp`` (ns; default: the wall clock now, as on ROS 2)."""
        import rospy

        with self._lock:
            if self._bag is not None:
                self._bag.write(topic, msg, rospy.Time(nsecs=time.time_ns() if stamp is None else stamp))
                self.count += 1

    def close(self) -> None:
        with self._lock:
            bag, self._bag = self._bag, None
        if bag is not None:
            bag.close()
