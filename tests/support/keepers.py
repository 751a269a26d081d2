"""Machines' keepers a test starts (``python -m ipyros.machine``, through tests/ros1/peers/keeper.py on either ROS),
each ended after the test with every process it started (its guards' stop processes, its basenodes, its relays'
hosts): waited for by pid, nothing else on the machine looked at."""

from __future__ import annotations

from helpers import descendants, pid_alive
from peer import PEERS, Peer
from support import wait_for

__all__ = ["Keepers"]

#: The keeper, as ``python -m ipyros.machine`` runs it, on either ROS.
KEEPER = PEERS / "keeper.py"


class Keepers:
    """Start keepers for one test (``start``), end them all after it (``end``)."""

    def __init__(self, ros: str) -> None:
        self.ros = ros  # "ROS 1", "ROS 2": what the ready line names
        self._started: list[Peer] = []

    def start(self, name: str, *allow: str) -> Peer:
        proc = Peer(str(KEEPER), "--name", name, *(f"--allow={package}" for package in allow))
        self._started.append(proc)
        proc.wait_line(f"ipyros machine {name} ready on {self.ros}", timeout=60)
        return proc

    def end(self) -> None:
        for proc in self._started:
            left = descendants(proc.proc.pid)
            proc.stop()
            wait_for(lambda: not any(pid_alive(pid) for pid in left), timeout=30, what="the keeper's children to end")
