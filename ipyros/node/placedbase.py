"""A basenode placed on another machine (``baseNode(EXE).basePackage(PKG).machine("robot1")``): the session's handle.

The keeper of that machine (see :mod:`ipyros.processes.keeper`) starts it there, as rosrun finds it, with
the remaps, name, namespace, parameters and arguments this session's model gives it; it runs beside the
robot's drivers, and ends with the keeper, or when this session is not heard for its grace. Here it is
the handle a local basenode's :class:`~ipyros.processes.basenode.BaseProcess` is: ``start``, ``stop``,
``restart``, ``running``, ``pid`` (on its machine), ``tail()`` (its log there), and the exit nobody
asked for told to ``on_exit`` with its last log lines, as the keeper reports it.
"""

from __future__ import annotations

import threading
import time
from typing import Any, Callable, Optional

from ..core.errors import BaseNodeError
from ..core.model import BaseModel
from ..processes.basenode import exit_reason
from ..processes.keeper import MachineError
from .keeperlink import KeeperLink

__all__ = ["PlacedBase", "placed_problem"]

#: How long the keeper may be silent (s) before the session says it has no word of a placed basenode.
SILENT = 2.0


def placed_problem(base: BaseModel) -> Optional[str]:
    """Why ``base`` cannot run on a machine's keeper, if it cannot: the keeper starts a package's executable by
    name, nothing else."""
    if base.launch or base.bag:
        return "a basenode from a launch file or a bag runs here"
    if not base.package or not base.executable:
        return "the keeper starts a package's executable by its name: give basePackage('pkg') and baseNode('exe')"
    if base.env:
        return "env= is not sent to a machine (the keeper starts nothing with an environment of a session's)"
    return None


class PlacedBase:
    """The session's handle on a basenode that the keeper of ``base.machine`` runs."""

    def __init__(self, base: BaseModel, backend: Any, host: str, say: Callable[[str], None],
                 on_exit: Optional[Callable[[Any, int, list[str]], None]] = None) -> None:
        assert base.machine is not None
        self.machine, self.node_name, self.on_exit = base.machine, base.node_name, on_exit
        self._base, self._say, self._backend, self._host = base, say, backend, host
        self._link = self._new_link()  # the token is read now: a one-line error before anything starts
        self._fresh = True
        self._started = False
        self._asked_end = False  # its end was asked for: not news
        self._told: Optional[int] = None  # the exit (its pid) told to on_exit already
        self._silent_said = False
        self._ended = threading.Event()

    def _new_link(self) -> KeeperLink:
        return KeeperLink(self._backend, self._host, self.machine, "bases", f"basenode {self._base.describe()}",
                          self._say)

    # -- state, as the keeper reports it ------------------------------------------------------------------
    @property
    def running(self) -> bool:
        return self._started and bool(self._link.report.get("running", True))

    @property
    def pid(self) -> Optional[int]:
        """Its process id on its machine, while it runs."""
        return self._link.report.get("pid") if self.running else None

    @property
    def returncode(self) -> Optional[int]:
        return self._link.report.get("returncode")

    def __repr__(self) -> str:
        state = f"running on {self.machine}, pid {self.pid}" if self.running else (
            "not started" if not self._started else f"on {self.machine}: {exit_reason(self.returncode)}")
        return f"<PlacedBase {self._base.describe()} ({state})>"

    # -- lifecycle ------------------------------------------------------------------------------------------
    def start(self) -> "PlacedBase":
        """Ask the keeper to start it; a one-line :class:`BaseNodeError` when it refuses or cannot be reached."""
        if not self._fresh:  # a link ends with the run it started: each start has its own id and lease
            self._link = self._new_link()
        self._fresh, self._asked_end, self._told = False, False, None
        link, base = self._link, self._base
        link.open(self._report)
        spec = {"package": base.package, "executable": base.executable, "node_name": base.node_name,
                "namespace": base.namespace, "remaps": base.remaps, "params": base.params, "args": base.args,
                "grace": base.machine_grace}
        try:
            answer = link.ask("start_base", base=spec)
        except MachineError as error:
            link.close()
            raise BaseNodeError(f"basenode {base.describe()} on {self.machine}: {error}") from None
        link.report = {"running": True, "pid": answer.get("pid")}
        link.heard_at = time.monotonic()
        link.beat(0.2)
        self._started = True
        self._ended.clear()
        threading.Thread(target=self._watch, name=f"ipyros-placed-{link.id}", daemon=True).start()
        return self

    def stop(self, timeout: float = 5.0) -> Optional[int]:
        """Ask the keeper to stop it; its exit code there (None if it could not be asked: its grace ends it)."""
        if not self._started:
            return None
        self._asked_end = True
        self._ended.set()
        try:
            answer = self._link.ask("stop_base", timeout=max(timeout, 3.0))
        except MachineError as error:
            self._say(f"ipyros: basenode {self._base.describe()}: {error}; its keeper stops it once this session is "
                      f"silent for its grace")
            answer = {}
        finally:
            self._link.close()
            self._started = False
        self._link.report = {"running": False, "returncode": answer.get("returncode")}
        return answer.get("returncode")

    def restart(self, timeout: float = 5.0) -> "PlacedBase":
        if not self._started:
            return self.start()
        self._asked_end = True
        try:
            answer = self._link.ask("restart_base", timeout=max(timeout, 10.0))
        except MachineError as error:
            raise BaseNodeError(f"basenode {self._base.describe()} on {self.machine}: {error}") from None
        finally:
            self._asked_end = False
        self._told = None
        self._link.report = {**self._link.report, "running": True, "pid": answer.get("pid"), "returncode": None}
        return self

    def tail(self, n: int = 20) -> list[str]:
        """The last ``n`` lines of its log, on its machine."""
        try:
            return list(self._link.ask("tail_base", timeout=5.0, lines=n).get("lines", []))
        except MachineError as error:
            return [f"[ipyros] its log on {self.machine} cannot be read: {error}"]

    # -- what the keeper reports ------------------------------------------------------------------------------
    def _report(self, report: dict[str, Any]) -> None:
        if report.get("running") or self._asked_end or self.on_exit is None:
            return
        key = report.get("returncode")
        if self._told is not None and self._told == key:
            return
        self._told = key
        self.on_exit(self, int(key or 0), list(report.get("tail") or []))

    def _watch(self) -> None:
        """Say when the keeper's reports stop (its link lost, the keeper gone: its basenodes end with it), and when
        they come again."""
        while not self._ended.wait(0.5):
            silent = time.monotonic() - self._link.heard_at
            if not self._silent_said and silent > SILENT:
                self._silent_said = True
                self._say(f"ipyros: basenode {self._base.describe()}: no word from machine {self.machine} for "
                          f"{silent:.1f} s: its keeper ended (its basenodes end with it) or the link is lost")
            elif self._silent_said and silent < SILENT:
                self._silent_said = False
                self._say(f"ipyros: basenode {self._base.describe()}: machine {self.machine} heard again")
