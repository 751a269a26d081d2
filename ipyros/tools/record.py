"""Recording live topics to a bag from the session: the data a basenode plays back later (``baseBag``).

A :class:`Recording` subscribes to each topic through a small DSL node of its own (as
``%echo`` does) and writes every message as it arrives; it runs in the background until
:meth:`Recording.stop` or its duration is up. ROS 1 bags through Debian's python3-rosbag
(:mod:`ipyros.ros1.bagfile`), ROS 2 bags through rosbags (:mod:`ipyros.ros2.bagfile`).
"""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Any, Callable, Mapping, Optional

from ..core.names import tool_name
from ..core.progress import Progress, no_progress
from ..core.text import counted
from ..dsl import rosNode
from ..node.session import current

__all__ = ["Recording", "bag_module"]


def bag_module() -> Any:
    """The session's ROS's bag files: ROS 1's (python3-rosbag) or ROS 2's (rosbags), as its backend gives them."""
    return current().backend.bags()


class Recording:
    """``topics`` ({name: type}) written to the bag ``path`` from now on, for ``duration`` seconds or until stopped;
    ``storage`` as the session's ROS writes bags (ROS 2: ``mcap``, the default, or ``sqlite3``).

    A recording for a ``duration`` shows its ``progress`` (the seconds gone, from a thread of its own, as the
    prompt stays free) and, when its time is up, tells the session how many messages it wrote where.
    """

    def __init__(self, path: Path, topics: Mapping[str, str], duration: Optional[float] = None,
                 storage: Optional[str] = None, keep: Optional[Callable[[Any, str], bool]] = None,
                 progress: Progress = no_progress) -> None:
        bagfile = bag_module()

        self.path, self.topics, self.duration = Path(path), dict(topics), duration
        self._stopping = threading.Lock()
        self._writer = bagfile.BagWriter(self.path, storage)
        self._keep = keep
        self.problem: Optional[str] = None  # why it stopped early: its filter failed on a message
        self._node: Optional[rosNode] = rosNode(tool_name("record"))
        for topic, type_name in self.topics.items():
            self._node.new.subscribe(topic, handler=lambda msg, topic=topic: self._write(topic, msg),
                                     msgType=type_name)
        try:
            self._node.create()
        except BaseException:
            self._writer.close()
            raise
        self._ended = threading.Event()
        self._timer = threading.Timer(duration, self._time_up) if duration else None
        self._shown: Optional[threading.Thread] = None
        if self._timer is not None and duration:
            self._timer.daemon = True
            self._timer.start()
            self._shown = threading.Thread(target=self._show, args=(progress, duration), daemon=True,
                                           name="ipyros-record-progress")
            self._shown.start()

    def _show(self, progress: Progress, duration: float) -> None:
        started = time.monotonic()
        with progress(f"recording {', '.join(self.topics)} to {self.path.name}", duration, "s") as step:
            while not self._ended.wait(1 / 4):
                step(min(duration, time.monotonic() - started))

    def _time_up(self) -> None:
        self.stop()
        if self.problem is None:
            current().notify(f"ipyros: recorded {counted(self.count, 'message')} of {', '.join(self.topics)} to "
                             f"{self.path} (its {self.duration:g} s are up)")

    def _write(self, topic: str, msg: Any) -> None:
        keep = self._keep
        if keep is not None:
            try:
                if not keep(msg, topic):
                    return
            except Exception as error:  # noqa: BLE001 - said once, and the recording stops: the bag holds what passed
                if self.problem is None:
                    self.problem = str(error)
                    current().notify(f"ipyros: %record to {self.path} stopped: {error}")
                    threading.Thread(target=self.stop, name="ipyros-record-stop", daemon=True).start()
                return
        self._writer.write(topic, msg)

    @property
    def running(self) -> bool:
        return self._node is not None

    @property
    def count(self) -> int:
        return self._writer.count

    @property
    def writer(self) -> Any:
        """The bag writer (its ``storage`` says how a ROS 2 folder stores the messages)."""
        return self._writer

    def stop(self) -> "Recording":
        """Stop and close the bag (twice does nothing)."""
        if self._timer is not None:
            self._timer.cancel()
        self._ended.set()
        if self._shown is not None and self._shown is not threading.current_thread():
            self._shown.join(timeout=2)  # the progress is gone before the stop is said
        with self._stopping:  # the timer's thread and the prompt may both stop it
            if self._node is not None:
                self._node.shutdown()
                self._writer.close()
                self._node = None  # running is False once it is all done
        return self

    def __repr__(self) -> str:
        state = "recording" if self.running else "closed"
        return f"<Recording of {', '.join(self.topics)} to {self.path} ({state}): {counted(self.count, 'message')}>"
