"""``%record``: live topics written to a bag in the background, for a basenode to play back (``baseBag``);
``%bag info``: what a bag holds; ``%bag convert IN OUT``: a bag rewritten (ROS 1 ↔ rosbag2, filtered);
``%bag pause nd`` (resume, step, seek, rate, loop, state): the bag a node plays.

    %record run.bag /turtle1/pose /turtle1/cmd_vel --duration 20
    %record --stop
    %bag info run.bag
    %bag convert run.bag run2 --topics /odom --start 5 --end 20 --filter 'm.twist.twist.linear.x > 0'
    %bag pause nd
    %bag seek nd 12.5
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Optional

from IPython.core.error import UsageError
from IPython.core.magic import line_magic, magics_class
from IPython.core.magic_arguments import magic_arguments, parse_argstring

from ...core.errors import IpyrosError
from ...core.progress import no_progress
from ...files.bagconvert import Converted, convert
from ...tools.bagplay import CONTROLS, control
from ...tools.record import Recording, bag_module
from ..api import compile_filter, find_node, global_topic, live_graph, live_type
from ..arguments import TOPIC, argument
from ..widgets import BagPlayerForm
from .cell_output import in_kernel
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
    @argument("--filter", default=None, help="record only the messages this Python expression is true for: m is "
              "the message, topic its topic, e.g. 'm.linear.x != 0'")
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
        test = compile_filter(args.filter, self.shell.user_ns) if args.filter is not None else None
        keep = (lambda m, topic: test(m, topic=topic)) if test is not None else None
        self.stop()
        # Its progress only in Jupyter: in a terminal the prompt stays free, and a bar would write over what is typed.
        shown = self.ext.session.progress if in_kernel(self.shell) else no_progress
        self.recording = Recording(path, topics, args.duration, args.storage, keep, shown)
        until = f"for {args.duration:g} s" if args.duration else "until %record --stop"
        storage = getattr(self.recording.writer, "storage", "")
        print(f"ipyros: recording {', '.join(topics)} to {path}{f' ({storage})' if storage else ''} {until}")
        return self.recording

    @magic_arguments()
    @argument("action", choices=("info", "convert", *CONTROLS, "widget"), help="info: what the bag FILE holds; "
              "convert: FILE to OUT; pause, resume, step [N], seek SECONDS, rate R, loop on|off, state: the bag NODE "
              "plays (baseBag), while it plays; widget: those controls in Jupyter")
    @argument("target", help="info, convert: the bag (a ROS 1 .bag file, a rosbag2 folder, an .mcap file); "
              "the rest: the variable holding the node that plays it")
    @argument("value", nargs="?", default="", help="convert: the bag to write (a .bag: ROS 1; else a rosbag2 "
              "folder); step: how many messages (1); seek: seconds from the bag's start; rate: the speed factor; "
              "loop: on or off")
    @argument("--topics", nargs="+", complete=TOPIC, help="convert: only these topics")
    @argument("--start", type=float, help="convert: from this many seconds after the bag's start")
    @argument("--end", type=float, help="convert: up to this many seconds after the bag's start")
    @argument("--filter", help="convert: keep the messages this Python expression is true for: m is the message, "
              "topic its topic, t its seconds from the bag's start, e.g. 'm.linear.x > 0'")
    @argument("--storage", choices=("mcap", "sqlite3"), help="convert: how a rosbag2 folder stores its messages "
              "(default: mcap)")
    @line_magic
    def bag(self, line: str) -> Any:
        """What a bag holds (info: each topic with its type and message count, the storage, start, end and
        duration, as rosbag info / ros2 bag info); or drive the bag a node plays, while it plays: where it
        stands after (bag time, paused or playing, rate, looping, messages sent)."""
        args = parse_argstring(self.bag, line)
        converting = (args.topics, args.start, args.end, args.filter, args.storage)
        if args.action != "convert" and any(option is not None for option in converting):
            raise UsageError("--topics, --start, --end, --filter and --storage are for %bag convert IN OUT")
        if args.action == "convert":
            return self._convert(args)
        if args.action == "widget":
            if not in_kernel(self.shell):
                raise UsageError(f"widgets need Jupyter: %bag widget draws the player's controls in a notebook; here "
                                 f"type them: %bag pause {args.target}, %bag seek {args.target} 12.5, ...")
            node = find_node(self.shell, args.target)
            return BagPlayerForm(lambda text: control(node, text))
        if args.action != "info":
            wants = {"seek": ("seconds from the bag's start", "12.5"), "rate": ("a speed factor", "2"),
                     "loop": ("on or off", "on")}
            if args.action in wants and not args.value:
                what, example = wants[args.action]
                raise UsageError(f"%bag {args.action} {args.target} needs {what}, e.g. "
                                 f"%bag {args.action} {args.target} {example}")
            # shown once, as the cell's result (state = %bag pause nd keeps it)
            return control(find_node(self.shell, args.target), f"{args.action} {args.value}".strip())
        path = Path(args.target).expanduser()
        if not path.exists():
            raise UsageError(f"no bag at {path}: give a bag file or a rosbag2 folder (%record writes one)")
        return bag_module().bag_info(path)  # shown once, as the cell's result (info = %bag info keeps it)

    def _convert(self, args: Any) -> Converted:
        if not args.value:
            raise UsageError(f"give the bag to write: %bag convert {args.target} OUT (OUT.bag: ROS 1; a folder: "
                             "rosbag2)")
        test = compile_filter(args.filter, self.shell.user_ns) if args.filter is not None else None
        keep = (lambda m, topic, t: test(m, topic=topic, t=t)) if test is not None else None
        try:  # shown once, as the cell's result (c = %bag convert ... keeps it)
            return convert(Path(args.target), Path(args.value), args.topics, args.start, args.end, keep,
                           args.storage, self.ext.session.progress)
        except KeyboardInterrupt:
            raise IpyrosError(f"stopped by Ctrl-C: {args.value} was not written (what was written of it is "
                              "removed)") from None
