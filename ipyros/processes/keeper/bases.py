"""A basenode a session placed on this machine: an allowed package's executable, by name, started as the
keeper's child, and stopped when its session is silent past its grace."""

from __future__ import annotations

import re
from typing import Any

from ...core import names
from ...core.errors import IpyrosError
from ...core.model import BaseModel
from ..basenode import BaseProcess, exit_reason, log_dir
from .lease import Lease, Refused, beat_topics, checked_grace
from .ros import REPORT, Keeping, Reporter

__all__ = ["KeptBase"]

#: An executable as a placed basenode's request may name it: a name in its package, never a path or a shell line.
_EXECUTABLE = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.+-]{0,127}$")

#: The most arguments, and the longest, a placed basenode's request may give it.
_MOST_ARGS, _LONGEST_ARG = 64, 4096


class KeptBase:
    """A basenode placed on this machine by a session: its process, the keeper's child (it ends with the keeper),
    and its session's lease (past its grace, the keeper stops it; grace None: it is left running)."""

    def __init__(self, keeper: Keeping, owner: str, bid: str, spec: dict[str, Any]) -> None:
        self.owner, self.id, self._log = owner, bid, keeper.log
        base = _base_of(spec, keeper.allowed)
        self.what = base.describe()
        try:
            argv = keeper.ros.basenode_command(base)
        except IpyrosError as error:
            raise Refused(str(error)) from None
        grace = checked_grace(spec.get("grace", 30.0), f"basenode {self.what}")
        self.lease = Lease(float("inf"), grace, keeper.clock())
        self._last_lines: list[str] = []
        #: Its exit nobody asked for was read (its last lines with it): reported as ended from then on, not at the
        #: moment the process is gone (its exit watch may be reading its log still: the report would lack them).
        self.ended = False
        self.process = BaseProcess(argv, node_name=base.node_name, on_exit=self._exited,
                                   log_path=log_dir() / f"machine_{keeper.name}_base_{bid}.log")
        try:
            self.process.start()
        except IpyrosError as error:
            raise Refused(f"basenode {self.what}: {error}") from None
        self._reporter = Reporter(keeper.ros, f"{keeper.ns}/bases/{bid}/state")
        self._beats = [keeper.ros.subscribe(topic, "std_msgs/String", keeper.beat, lossy=True)
                       for topic in beat_topics(f"{keeper.ns}/bases/{bid}")]

    def _exited(self, process: Any, returncode: int, last_lines: list[str]) -> None:
        self._last_lines = last_lines[-8:]  # told in each report from now on: the log read once, not every 0.2 s
        self.ended = True
        self._log(f"basenode {self.what} of {self.owner} {exit_reason(returncode)}")

    def state(self) -> dict[str, Any]:
        process = self.process
        running = not self.ended
        return {"id": self.id, "base": self.what, "running": running, "pid": process.pid,
                "returncode": process.returncode, "tail": [] if running else self._last_lines}

    def report(self, now: float, every: float = REPORT) -> None:
        self._reporter.report(self.state(), now, every)

    def close(self) -> None:
        for sub in self._beats:
            sub.close()
        self.process.stop()
        self._reporter.close()


def _base_of(spec: dict[str, Any], allowed: frozenset[str]) -> BaseModel:
    """The basenode a request names, checked: an allowed package's executable by name, and ROS names, arguments and
    parameters of the right shape; :class:`Refused` in one line otherwise. Nothing of it is a path or a shell."""
    package, executable = spec.get("package"), spec.get("executable")
    if not isinstance(package, str) or package not in allowed:
        allows = ", ".join(sorted(allowed)) or "nothing"
        raise Refused(f"package {package!r:.60} is not allowed on this machine (its keeper allows {allows}): start "
                      f"the keeper with --allow {package if isinstance(package, str) else 'PACKAGE'}")
    if not isinstance(executable, str) or not _EXECUTABLE.match(executable):
        raise Refused(f"executable {executable!r:.60}: give its name in package {package}, never a path or a "
                      "shell line")
    args, remaps, params = spec.get("args") or [], spec.get("remaps") or {}, spec.get("params") or {}
    if not isinstance(args, list) or len(args) > _MOST_ARGS or \
            not all(isinstance(a, str) and len(a) <= _LONGEST_ARG for a in args):
        raise Refused(f"basenode {package}/{executable}: args must be a list of at most {_MOST_ARGS} strings")
    if not isinstance(remaps, dict) or not isinstance(params, dict):
        raise Refused(f"basenode {package}/{executable}: remaps and params must be objects")
    try:
        for source, target in remaps.items():
            names.check_remap(source, target)
            if source.startswith("__"):
                raise Refused(f"basenode {package}/{executable}: remap {source}:= is the keeper's to set")
        for key in params:
            names.check_param_key(key, f"basenode {package}/{executable}")
        node_name = names.check_node_name(spec.get("node_name") or executable.split(".")[0])
        given = spec.get("namespace")
        namespace = names.check_namespace(given) if given and given != "/" else None  # as rosrun: none given
    except IpyrosError as error:
        raise Refused(str(error)) from None
    return BaseModel(executable=executable, package=package, node_name=node_name, namespace=namespace,
                     remaps=dict(remaps), params=dict(params), args=list(args))
