"""A bag rewritten: ROS 1 bag ↔ rosbag2 folder (MCAP or sqlite3), with topic, time and content filters.

``%bag convert run.bag run2 --topics /odom --start 5 --end 20 --filter 'm.twist.twist.linear.x > 0'``
reads any bag rosbags reads (a ROS 1 ``.bag``, a rosbag2 folder in either storage, a bare
``.mcap``) and writes the messages kept, in recorded order with their recorded stamps: to a
ROS 1 ``.bag`` when the target ends in ``.bag``, else to a rosbag2 folder (MCAP unless
``storage="sqlite3"``). Messages change serialization on the way (ROS 1 ↔ CDR) with the
definitions the source carries, so types this Python lacks convert too. A filter gets each
message as rosbags reads it (fields by name: ``m.linear.x``), its topic and its time from the
bag's start. Pure rosbags: no ROS library is needed, on either ROS's venv.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Optional, Sequence

from ..core.errors import DeclarationError, first_line
from ..core.progress import Progress, Step, no_progress
from ..core.records import short_repr

__all__ = ["Converted", "convert"]

#: What decides whether a message is kept: ``keep(message, topic, seconds from the bag's start)``.
Keep = Callable[[Any, str, float], bool]


@dataclass(frozen=True, repr=False)
class Converted:
    """What a conversion wrote: how many messages of how many read, of which topics."""

    source: str
    target: str
    kept: int
    read: int
    topics: tuple[str, ...]

    def __str__(self) -> str:
        return (f"{self.target}: {self.kept} of {self.read} message{'s' * (self.read != 1)} of "
                f"{', '.join(self.topics) or 'no topic'} from {self.source}")

    def __repr__(self) -> str:
        return short_repr(self, str(self), limit=200)


def _rosbags() -> Any:
    try:
        import rosbags.highlevel  # noqa: F401 - what the rest below uses
    except ImportError:
        raise DeclarationError("converting bags needs rosbags: pip install rosbags (bash run.sh installs it)") from None
    import rosbags

    return rosbags


def convert(source: Path, target: Path, topics: Optional[Sequence[str]] = None, start: Optional[float] = None,
            end: Optional[float] = None, keep: Optional[Keep] = None, storage: Optional[str] = None,
            progress: Progress = no_progress) -> Converted:
    """Write the messages of ``source`` that pass the filters to ``target`` (see the module's docstring).

    ``topics``: only these; ``start``/``end``: seconds from the bag's start; ``keep``: a content filter;
    ``progress`` shows how far it got (:mod:`ipyros.core.progress`). Nothing is left behind when it fails (Ctrl-C
    too): a half-written target is removed.
    """
    _rosbags()
    from rosbags.highlevel import AnyReader

    source, target = Path(source).expanduser(), Path(target).expanduser()
    if not source.exists():
        raise DeclarationError(f"no bag at {source}: give a .bag file, a rosbag2 folder or an .mcap file")
    if target.exists():
        raise DeclarationError(f"{target} exists; give a new name (a conversion never overwrites a bag)")
    ros1_out = target.suffix == ".bag"
    if ros1_out and storage not in (None, "bag"):
        raise DeclarationError(f"storage={storage!r}: a .bag target is a ROS 1 bag; name a folder for rosbag2")
    if not ros1_out and storage not in (None, "mcap", "sqlite3"):
        raise DeclarationError(f"storage={storage!r}: a rosbag2 folder stores mcap (the default) or sqlite3")
    try:
        reader = AnyReader([source])
        reader.open()
    except Exception as error:  # noqa: BLE001 - rosbags' errors of any kind: not a bag it reads
        raise DeclarationError(f"cannot read the bag {source}: {first_line(error)}") from None
    try:
        recorded = sorted({c.topic for c in reader.connections})
        missing = sorted(set(topics or ()) - set(recorded))
        if missing:
            raise DeclarationError(f"{source.name} has no topic {', '.join(missing)}; it has "
                                   f"{', '.join(recorded) or 'none'} (%bag info {source})")
        length = (reader.end_time - reader.start_time) / 1e9
        for name, value in (("start", start), ("end", end)):
            if value is not None and not 0 <= value <= length + 1e-9:
                raise DeclarationError(f"--{name} {value:g}: the bag lasts {length:.3f} s; give seconds from its "
                                       "start, 0 to that")
        if start is not None and end is not None and end < start:
            raise DeclarationError(f"--end {end:g} is before --start {start:g}")
        connections = [c for c in reader.connections if not topics or c.topic in topics]
        window = (None if start is None else reader.start_time + int(start * 1e9),
                  None if end is None else reader.start_time + int(end * 1e9) + 1)
        total = sum(getattr(c, "msgcount", 0) for c in connections) or None
        try:
            with progress(f"converting {source.name}", total, "messages") as step:
                return _write(reader, connections, source, target, ros1_out, storage or "mcap", window, keep, step)
        except BaseException:
            _remove(target)
            raise
    finally:
        reader.close()


def _write(reader: Any, connections: list, source: Path, target: Path, ros1_out: bool, storage: str,
           window: tuple[Optional[int], Optional[int]], keep: Optional[Keep], step: Step) -> Converted:
    from rosbags.rosbag1 import Writer as Ros1Writer
    from rosbags.rosbag2 import StoragePlugin, Writer as Ros2Writer

    store = reader.typestore
    writer: Any = Ros1Writer(target) if ros1_out else Ros2Writer(
        target, version=9, storage_plugin=StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3)
    read = kept = 0
    try:
        writer.open()
    except Exception as error:  # noqa: BLE001 - a folder that cannot be made, a file that cannot be written
        raise DeclarationError(f"cannot write {target}: {first_line(error)}") from None
    try:
        out: dict[int, Any] = {}
        for connection, stamp, raw in reader.messages(connections=connections, start=window[0], stop=window[1]):
            read += 1
            if not read & 1023:
                step(read)
            ros1_in = connection.msgtype and _is_ros1(connection)
            if keep is not None:
                message = store.deserialize_ros1(raw, connection.msgtype) if ros1_in else \
                    store.deserialize_cdr(raw, connection.msgtype)
                if not keep(message, connection.topic, (stamp - reader.start_time) / 1e9):
                    continue
            if connection.id not in out:
                out[connection.id] = writer.add_connection(connection.topic, connection.msgtype, typestore=store)
            if ros1_in != ros1_out:
                raw = store.ros1_to_cdr(raw, connection.msgtype) if ros1_in else store.cdr_to_ros1(raw,
                                                                                                   connection.msgtype)
            writer.write(out[connection.id], stamp, raw)
            kept += 1
    finally:
        writer.close()
    return Converted(str(source), str(target), kept, read, tuple(sorted({c.topic for c in connections})))


def _is_ros1(connection: Any) -> bool:
    """Whether a connection's messages are ROS 1 serialized (a ROS 1 bag's), not CDR."""
    return type(connection.ext).__name__ == "ConnectionExtRosbag1"


def _remove(target: Path) -> None:
    if target.is_dir():
        shutil.rmtree(target, ignore_errors=True)
    else:
        target.unlink(missing_ok=True)
