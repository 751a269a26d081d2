"""A basenode from a launch file and the rest of that file, held as one handle (``nd.base``).

Each ROS starts the rest its own way (ROS 1: roslaunch's runner in one child process;
ROS 2: each other node a child process); what is the same lives here: the handle behaves
like the basenode's :class:`~ipyros.processes.basenode.BaseProcess` (``tail``,
``restart``, ``running``, ``pid``, ``log_path`` are the basenode's), ``rest`` is the rest
(``rest.tail()``), ``stop()`` stops the basenode and then the rest, and an exit of the
rest after the start is told through ``on_rest_exit``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Optional

from ..core.errors import BaseNodeError
from ..core.model import BaseModel
from .basenode import BaseProcess, OnExit

__all__ = ["LaunchedBase", "launch_file"]


def launch_file(text: str, shown: str, example: str) -> Path:
    """The launch file at ``text`` (``~`` expanded, relative to the working dir), or one line saying it is not there."""
    path = Path(text).expanduser()
    if not path.is_absolute():
        path = Path.cwd() / path
    if not path.is_file():
        where = "" if Path(text).expanduser().is_absolute() else f" (relative to {Path.cwd()})"
        raise BaseNodeError(f"launch file {shown!r} not found{where}; give its path, or {example!r}")
    return path


class LaunchedBase:
    """The shared half of a launch handle; a subclass sets ``rest`` (with ``stop(timeout)``) and ``start()``."""

    rest: Any

    def __init__(self, base: BaseModel, basenode: BaseProcess, *, node: str,
                 on_rest_exit: Optional[OnExit] = None) -> None:
        """``base`` as declared (launch file, node in it); ``basenode`` its process, running as ``node``."""
        if not base.launch or not base.launch_node:
            raise BaseNodeError("this basenode was not read from a launch file; declare it with baseLaunch(file, node)")
        self.launch, self.node, self.basenode, self.on_rest_exit = base.launch, node, basenode, on_rest_exit
        self._up = False  # an exit during start() is start()'s to raise, not a notice as well

    def rest_stop_timeout(self, timeout: float) -> float:
        """How long the rest may take to stop."""
        return timeout

    def stop(self, timeout: float = 5.0) -> Optional[int]:
        """Stop the basenode, then the rest of the launch; return the basenode's exit code."""
        try:
            return self.basenode.stop(timeout)
        finally:
            self.rest.stop(self.rest_stop_timeout(timeout))

    def restart(self, timeout: float = 5.0) -> "LaunchedBase":
        """Restart the basenode alone; the rest of the launch keeps running."""
        self.basenode.restart(timeout)
        return self

    def tail(self, n: int = 20) -> list[str]:
        """The last ``n`` lines of the basenode's log (``rest.tail(n)`` for the rest's)."""
        return self.basenode.tail(n)

    @property
    def running(self) -> bool:
        return self.basenode.running

    @property
    def pid(self) -> Optional[int]:
        return self.basenode.pid

    @property
    def returncode(self) -> Optional[int]:
        return self.basenode.returncode

    @property
    def log_path(self) -> Path:
        return self.basenode.log_path

    def _rest_exited(self, proc: BaseProcess, returncode: int, last_lines: list[str]) -> None:
        if self._up and self.on_rest_exit is not None:
            self.on_rest_exit(proc, returncode, last_lines)
