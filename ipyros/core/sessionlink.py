"""What a backend reads and asks of the session it serves: the seam between a ROS and the nodes above it.

A backend (``ros1/``, ``ros2/``) sits below the node layer and must not reach up into it. Yet it has duties that
concern the session's nodes: ROS 1's master, gone and back, means every created node registers its parameters again,
and a basenode that did not register with the restarted master is restarted or reported. So the session hands the
backend this link, typed here below both: its settings, where its notices go, and the two things the backend may ask
of its nodes, each answered by the session, which knows them (``ipyros.node.session.Session`` is one; a test's
stand-in is another). Nothing else of the session is the backend's to touch.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Optional, Protocol

__all__ = ["RunningBase", "SessionLink", "SessionSettings", "restart_unregistered"]


class SessionSettings(Protocol):
    """The settings a backend reads (``ipyros.node.session.SessionConfig``, set at the prompt by ``%config``)."""

    @property
    def master_uri(self) -> Optional[str]:
        """None: ROS_MASTER_URI, else http://localhost:11311 (ROS 1)."""

    @property
    def start_master(self) -> bool:
        """Start one on localhost when none answers (ROS 1)."""

    @property
    def process_node_name(self) -> Optional[str]:
        """None: the first node created names the process's ROS node."""

    @property
    def restart_basenodes(self) -> bool:
        """Restart basenodes that do not register with a restarted master (ROS 1)."""

    @property
    def announce(self) -> Callable[[str], None]:
        """Where a line goes at once, while the session starts."""


@dataclass(frozen=True)
class RunningBase:
    """A running basenode of one of the session's nodes, as a backend may need it: its ROS name, its node's name,
    how advice names that node (``nd``), and how to restart it."""

    name: str
    node: str
    called: str
    restart: Callable[[], None]


class SessionLink(Protocol):
    """The session as its backend sees it (see the module's docstring)."""

    @property
    def config(self) -> SessionSettings:
        """Its settings, as they are now (``%config`` replaces them)."""

    @property
    def closed(self) -> bool:
        """Whether it has ended."""

    def notify(self, text: str) -> None:
        """Tell the user something that happened on its own (the master went away, ...)."""

    def register_params_again(self) -> int:
        """Every created node's parameters registered again (a ROS 1 master is back); how many there were."""

    def running_basenodes(self) -> list[RunningBase]:
        """The basenodes running now, one per node that wraps one."""


def restart_unregistered(bases: list[RunningBase], registered: Callable[[str], bool], restart: bool) -> list[str]:
    """After a ROS 1 master restart: each running basenode in ``bases`` that is not ``registered`` with it (ROS 1
    nodes do not register again by themselves) restarted if ``restart`` (the session's ``restart_basenodes``), and
    what to tell the user of each: that it was restarted, or the line that restarts it."""
    said = []
    for base in bases:
        if registered(base.name):
            continue
        if restart:
            try:
                base.restart()
            except Exception as error:  # noqa: BLE001 - said, and the others still looked at
                said.append(f"ipyros: basenode {base.name} of {base.node} did not register with the restarted master "
                            f"and could not be restarted ({error}); restart it: {base.called}.base.restart()")
                continue
            said.append(f"ipyros: basenode {base.name} of {base.node} did not register with the restarted master; "
                        "restarted it")
        else:
            said.append(f"ipyros: basenode {base.name} of {base.node} did not register with the restarted master "
                        f"(ROS 1 nodes do not); restart it: {base.called}.base.restart()")
    return said
