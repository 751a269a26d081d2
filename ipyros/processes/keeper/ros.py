"""What the keeper asks of its ROS (:class:`KeeperRos`: one small adapter a ROS, ``ros1/machine``,
``ros2/machine``), how it reports a thing it keeps to its session (:class:`Reporter`), and the
environment of the processes it starts from this package (:func:`child_env`)."""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path
from typing import Any, Callable, Optional, Protocol

from ...core.guard import Guarding
from ...core.model import BaseModel
from ..relayhost import Relaying

__all__ = ["Closing", "KeeperRos", "Keeping", "Lookup", "Outlet", "REPORT", "Reporter", "child_env"]

#: How often a guard's state is sent to its session when nothing changed (s): the session hears that the link holds.
REPORT = 0.2


class Outlet(Protocol):
    """A publisher the adapter made."""

    def write(self, msg: Any) -> None: ...
    def count(self) -> int: ...  # the subscribers it reaches
    def close(self) -> None: ...


class Closing(Protocol):
    def close(self) -> None: ...


class KeeperRos(Protocol):
    """What the keeper asks of its ROS (one adapter a ROS)."""

    name: str  # "ROS 1", "ROS 2"

    def address(self) -> str: ...  # where sessions find it (its master, its domain)
    def publisher(self, topic: str, type_name: str, latch: bool) -> Outlet: ...
    # lossy: a heartbeat's, where a newer one makes a lost one moot (ROS 2: best effort, never held up behind a
    # lost sample being repaired; ROS 1 has TCP only)
    def subscribe(self, topic: str, type_name: str, callback: Callable[[Any], None],
                  lossy: bool = False) -> Closing: ...
    def text(self, data: str) -> Any: ...  # a std_msgs/String
    def deserialize(self, cls: type, data: bytes) -> Any: ...
    def sentinel_command(self) -> list[str]: ...
    def basenode_command(self, base: BaseModel) -> list[str]: ...  # found as rosrun / the ament index finds it
    def has_package(self, package: str) -> bool: ...
    def executables(self, package: str) -> list[str]: ...
    # a relay of a placed basenode's topic; ``gate``: the guard's on ``target`` it passes from its first message
    def relay(self, source: str, target: str, type_name: str, gate: Optional[Guarding],
              complain: Callable[[str], None]) -> Relaying: ...
    def relay_host_command(self, name: str) -> list[str]: ...  # a relay host whose ROS node is ``name``


class Keeping(Protocol):
    """What a thing the keeper keeps (a guard, a basenode, relays) asks of the keeper: its ROS, its namespace and
    name, its log and steady clock, the packages it allows, and where the heartbeats it hears go."""

    ros: KeeperRos
    ns: str
    name: str
    allowed: frozenset[str]
    log: Callable[[str], None]
    clock: Callable[[], float]

    def beat(self, msg: Any) -> None: ...


class Lookup:
    """What a keeper's ROS adapter starts, as that ROS finds it: ``nodes`` is its module that finds a package's
    executables (rosrun's way, the ament index's) and makes a basenode's command line; ``sentinel`` the module a
    guard's stop process runs."""

    nodes: Any
    sentinel: str
    relay_host: str

    def sentinel_command(self) -> list[str]:
        return [sys.executable, "-m", self.sentinel]

    def relay_host_command(self, name: str) -> list[str]:
        return [sys.executable, "-m", self.relay_host, name]

    def basenode_command(self, base: BaseModel) -> list[str]:
        return list(self.nodes.command(base))

    def executables(self, package: str) -> list[str]:
        return list(self.nodes.list_executables(package))

    def has_package(self, package: str) -> bool:
        return package in self.nodes.list_packages()


class Reporter:
    """What the keeper tells a session of one thing it keeps, on a latched topic: at once when it changed, else
    every ``REPORT`` s (the session hears that the link holds)."""

    def __init__(self, ros: KeeperRos, topic: str) -> None:
        self._out, self._text = ros.publisher(topic, "std_msgs/String", True), ros.text
        self._reported: tuple = ()
        self._reported_at = -float("inf")

    def due(self, now: float, every: float = REPORT) -> bool:
        """Whether a report of what changes only in figures is due (the others: :meth:`report` tells at once)."""
        return now - self._reported_at >= every

    def report(self, state: dict[str, Any], now: float, every: float = REPORT, steady: tuple[str, ...] = ()) -> None:
        key = tuple((k, str(v)) for k, v in state.items() if k not in steady)
        if key != self._reported or now - self._reported_at >= every:
            self._reported, self._reported_at = key, now
            self._out.write(self._text(json.dumps({**state, "at": now})))

    def close(self) -> None:
        self._out.close()


def child_env() -> dict[str, str]:
    """The environment of a process the keeper starts from this package (a stop process, a relay host): ipyros
    importable as it is here."""
    env = dict(os.environ)
    package_root = str(Path(__file__).resolve().parents[2])
    env["PYTHONPATH"] = os.pathsep.join(p for p in (package_root, env.get("PYTHONPATH")) if p)
    return env
