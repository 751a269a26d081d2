"""``%record``: live topics written to a bag in the background, for a basenode to play back (``baseBag``);
``%bag info``: what a bag holds.

    %record run.bag /turtle1/pose /turtle1/cmd_vel --duration 20
    %record --stop
    %bag info run.bag
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Optional

from IPython.core.error import UsageError
from IPython.core.magic import line_magic, magics_class
from IPython.core.magic_arguments import magic_arguments, parse_argstring

from ...tools.record import Recording, bag_module
from ..api import global_topic, live_graph, live_type
from ..arguments import TOPIC, argument
from .common import ExtensionMagics


@magics_class
class RecordMagics(ExtensionMagics):
    """The magic that records topics to a bag; one recording at a time (``recording``)."""

    def __init__(self, shell: Any, ext: Any) -> None:
        super().__init__(shell, ext)
        self.recording: Optional[Recording] = None

    def stop(self) -> Optional[Recording]:
        """Stop the recording, if any (``%record --stop``, and when the extension is unloaded)."""
        stopped, self.recording = self.recording, None
        return stopped.stop() if stopped is not None else None

    @magic_arguments()
    @argument("file", nargs="?", help="the bag to write (ROS 1: a .bag file; ROS 2: a folder)")
    @argument("topics", nargs="*", complete=TOPIC, help="the live topics to record")
    @argument("--duration", type=float, default=None, help="stop after this many seconds (default: %%record --stop)")
    @argument("--stop", action="store_true", help="stop recording and close the bag")
    @argument("--storage", choices=("mcap", "sqlite3"), default=None,
              help="ROS 2: how the bag folder stores its messages (default: mcap, as rosbag2 records)")
    @line_magic
    def record(self, line: str) -> Optional[Recording]:
        """Record TOPICS to FILE in the background (the prompt stays free); return the Recording."""
        args = parse_argstring(self.record, line)
        if args.stop:
            stopped = self.stop()
            print(f"ipyros: recorded {stopped.count} messages of {', '.join(stopped.topics)} to {stopped.path}"
                  if stopped else "ipyros: nothing is being recorded")
            return stopped
        if not args.file or not args.topics:
            raise UsageError("give the bag to write and the topics: %record run.bag /turtle1/pose /turtle1/cmd_vel")
        if args.duration is not None and not 0 < args.duration <= 86400:
            raise UsageError(f"--duration is seconds, more than 0: not {args.duration}")
        path = Path(args.file).expanduser()
        if path.exists():
            raise UsageError(f"{path} exists; give a new file name (a recording never overwrites one)")
        snap = live_graph(self.ext)  # one read of the graph for every topic
        topics = {topic: live_type(self.ext, topic, snap=snap) for topic in map(global_topic, args.topics)}
        self.stop()
        self.recording = Recording(path, topics, args.duration, args.storage)
        until = f"for {args.duration:g} s" if args.duration else "until %record --stop"
        storage = getattr(self.recording.writer, "storage", "")
        print(f"ipyros: recording {', '.join(topics)} to {path}{f' ({storage})' if storage else ''} {until}")
        return self.recording

    @magic_arguments()
    @argument("action", choices=("info",), help="info: what the bag holds")
    @argument("file", help="the bag: ROS 1 a .bag file; ROS 2 a rosbag2 folder, an .mcap file or a .bag")
    @line_magic
    def bag(self, line: str) -> Any:
        """What a bag holds: each topic with its type and message count, the storage, start, end and duration
        (as rosbag info / ros2 bag info); return it as a record (its rows, start, end, duration)."""
        args = parse_argstring(self.bag, line)
        path = Path(args.file).expanduser()
        if not path.exists():
            raise UsageError(f"no bag at {path}: give a bag file or a rosbag2 folder (%record writes one)")
        info = bag_module().bag_info(path)
        self.ext.printer.show(info)
        return info
