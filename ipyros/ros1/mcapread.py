"""Reading an MCAP file of ROS 1 messages with mcap and mcap-ros1-support alone (no ipyros, no rospy): its summary,
its span, the classes of its topics from the definitions it carries, its messages decoded.

Two readers share it: :mod:`.mcapfile` (the session's view of a file, with one-line errors) and the bag
player (``bag_player.py``, run without ipyros, which imports it from its own folder).
"""

from __future__ import annotations

from typing import Any, Collection, Iterator, Optional

__all__ = ["message_classes", "messages", "span", "summary"]


def summary(path: Any) -> Any:
    """The file's summary (None if it was not closed when written); mcap's own errors if it reads no MCAP there,
    ImportError without mcap."""
    from mcap.reader import make_reader

    with open(path, "rb") as stream:
        return make_reader(stream).get_summary()


def span(found: Any) -> tuple[int, int]:
    """The first and last log times of a summary's messages (ns); (0, 0) for none."""
    stats = found.statistics
    return (stats.message_start_time, stats.message_end_time) if stats is not None and stats.message_count else (0, 0)


def message_classes(found: Any, topics: Optional[Collection[str]] = None) -> dict[str, type]:
    """The message class of each topic of a summary (of ``topics``, or all), made by genpy from its schema."""
    from genpy.dynamic import generate_dynamic

    classes = {}
    for channel in found.channels.values():
        if not topics or channel.topic in topics:
            schema = found.schemas[channel.schema_id]
            classes[channel.topic] = generate_dynamic(schema.name, schema.data.decode())[schema.name]
    return classes


def messages(path: Any, topics: Optional[Collection[str]] = None,
             start: Optional[int] = None) -> Iterator[tuple[str, int, Any]]:
    """``(topic, log time in ns, message)`` of each message of ``topics`` (all: None), in recorded order, from the
    log time ``start`` on."""
    from mcap.reader import make_reader
    from mcap_ros1.decoder import DecoderFactory

    with open(path, "rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        for _, channel, message, decoded in reader.iter_decoded_messages(
                topics=None if topics is None else list(topics), starting_at=start):
            yield channel.topic, message.log_time, decoded
