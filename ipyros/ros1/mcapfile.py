"""MCAP files of ROS 1 messages (the ``ros1`` profile: ``ros1msg`` schemas, ``ros`` encoding), through the mcap and
mcap-ros1-support packages: what one holds, its messages, writing one (``%record run.mcap``).

:mod:`.bagfile` hands a path ending in ``.mcap`` here; the player reads them too. Messages
come back as instances of classes genpy makes from the definitions the file carries, as
rosbag's are, so a type this Python lacks reads too.
"""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Any, Collection, Iterator, Optional

from ..core.errors import DeclarationError, first_line
from ..core.records import BagInfo, BagTopic
from . import mcapread

__all__ = ["McapWriter", "mcap_info", "mcap_messages", "mcap_topics"]


def _summary(path: Path) -> Any:
    try:
        found = mcapread.summary(path)
    except ImportError:
        raise DeclarationError("MCAP bags on ROS 1 need mcap and mcap-ros1-support: pip install 'ipyros[bags]' "
                               "(bash run.sh installs them)") from None
    except Exception as error:  # noqa: BLE001 - mcap's errors of any kind: not an MCAP file it reads
        raise DeclarationError(f"cannot read the MCAP file {path}: {first_line(error)}") from None
    if found is None:
        raise DeclarationError(f"the MCAP file {path} has no summary (it was not closed when written); "
                               "rewrite it with mcap recover")
    return found


def mcap_topics(path: Path) -> dict[str, str]:
    """The topics of the MCAP file at ``path``, with their types (``pkg/Type``)."""
    summary = _summary(path)
    return {channel.topic: summary.schemas[channel.schema_id].name for channel in summary.channels.values()}


def mcap_info(path: Path) -> BagInfo:
    """What the MCAP file at ``path`` holds, as :func:`.bagfile.bag_info` says of a bag."""
    summary = _summary(path)
    stats = summary.statistics
    counts = stats.channel_message_counts if stats is not None else {}
    rows = tuple(sorted(BagTopic(channel.topic, summary.schemas[channel.schema_id].name, counts.get(key, 0))
                        for key, channel in summary.channels.items()))
    start, end = mcapread.span(summary)
    return BagInfo(str(path), "mcap", start / 1e9, end / 1e9, rows)


def mcap_messages(path: Path, topics: Optional[Collection[str]] = None,
                  start: Optional[int] = None) -> Iterator[tuple[str, int, Any]]:
    """``(topic, log time in ns, message)`` of each message of ``topics`` (all: None), in recorded order, from the
    log time ``start`` on."""
    _summary(path)  # a one-line error first, if it is no MCAP file
    return mcapread.messages(path, topics, start)


class McapWriter:
    """ROS 1 messages written to a new MCAP file, from any thread, stamped with the wall clock on arrival."""

    storage = "mcap"

    def __init__(self, path: Path) -> None:
        try:
            from mcap_ros1.writer import Writer
        except ImportError:
            raise DeclarationError("MCAP bags on ROS 1 need mcap and mcap-ros1-support: pip install 'ipyros[bags]' "
                                   "(bash run.sh installs them)") from None
        try:
            self._stream: Any = open(path, "xb")
        except OSError as error:
            raise DeclarationError(f"cannot write {path}: {error.strerror or error}") from None
        self._writer: Any = Writer(self._stream)
        self._lock = threading.Lock()
        self.count = 0

    def write(self, topic: str, msg: Any, stamp: Optional[int] = None) -> None:
        """Write ``msg`` stamped ``stamp`` (ns; default: the wall clock now)."""
        with self._lock:
            if self._writer is not None:
                now = time.time_ns() if stamp is None else stamp
                self._writer.write_message(topic, msg, log_time=now, publish_time=now)
                self.count += 1

    def close(self) -> None:
        with self._lock:
            writer, self._writer = self._writer, None
        if writer is not None:
            writer.finish()
            self._stream.close()
