"""Find the ROS master, or start one on localhost when none answers.

A roboticist at a prompt should not have to open another terminal for ``roscore``:
if nothing answers at ``ROS_MASTER_URI`` (default ``http://localhost:11311``), ipyros
starts ``rosmaster --core`` (and ``rosout``) there itself, says so, and stops it when
the session ends. If a master answers it is used as it is.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
import xmlrpc.client
from dataclasses import dataclass, field
from typing import Optional
from urllib.parse import urlparse

from ..core.errors import MasterError
from ..processes.process import spawn, stop_process

DEFAULT_URI = "http://localhost:11311/"
LOOPBACK = "127.0.0.1"


class _TimeoutTransport(xmlrpc.client.Transport):
    def __init__(self, timeout: float) -> None:
        super().__init__()
        self._timeout = timeout

    def make_connection(self, host):  # type: ignore[override]
        conn = super().make_connection(host)
        conn.timeout = self._timeout
        return conn


def master_proxy(uri: str, timeout: float = 2.0) -> xmlrpc.client.ServerProxy:
    """An XML-RPC proxy to the master that gives up after ``timeout`` seconds."""
    return xmlrpc.client.ServerProxy(uri, transport=_TimeoutTransport(timeout))


def answers(uri: str, timeout: float = 0.5) -> bool:
    """Whether a ROS master answers at ``uri`` within ``timeout`` seconds."""
    try:
        code, _, _ = master_proxy(uri, timeout).getPid("/ipyros")
        return code == 1
    except (OSError, xmlrpc.client.Error):
        return False


def is_registered(uri: str, node: str, timeout: float = 2.0) -> bool:
    """Whether the master at ``uri`` has a node called ``node`` registered (False if it does not answer)."""
    try:
        code, _, _ = master_proxy(uri, timeout).lookupNode("/ipyros", node)
        return code == 1
    except (OSError, xmlrpc.client.Error):
        return False


def configured_uri() -> str:
    return os.environ.get("ROS_MASTER_URI") or DEFAULT_URI


@dataclass
class MasterHandle:
    """The master this session uses; ``process`` is set when ipyros started it."""

    uri: str
    started: bool
    processes: list[subprocess.Popen] = field(default_factory=list)

    def describe(self) -> str:
        how = ("started by ipyros, local: listening on 127.0.0.1 only; it stops when this session exits"
               if self.started else "found running")
        return f"ROS master {self.uri} ({how})"

    def stop(self) -> None:
        """Stop the master if ipyros started it (rosout first, the master last)."""
        for proc in reversed(self.processes):
            stop_process(proc)
        self.processes.clear()


def attach(uri: Optional[str] = None, start: bool = True, timeout: float = 15.0) -> MasterHandle:
    """Use the master at ``uri`` (default: ROS_MASTER_URI), starting one if allowed and needed.

    Sets ``ROS_MASTER_URI`` for this process and its children to the master in use.
    """
    uri = uri or configured_uri()
    if not uri.endswith("/"):
        uri += "/"
    if answers(uri):
        os.environ["ROS_MASTER_URI"] = uri
        return MasterHandle(uri, started=False)
    if not start:
        raise MasterError(f"no ROS master answers at {uri}; start roscore there, "
                          "or allow ipyros to start one (c.RosMagics.start_master = True)")
    parsed = urlparse(uri)
    if parsed.hostname not in ("localhost", "127.0.0.1", "::1", os.uname().nodename):
        raise MasterError(f"no ROS master answers at {uri} and ipyros can only start one on this machine; "
                          "start roscore on that host or point ROS_MASTER_URI at localhost")
    if shutil.which("rosmaster") is None:
        raise MasterError("no ROS master answers and 'rosmaster' is not installed; "
                          "apt-get install python3-rosmaster (or run: bash run.sh)")
    port = parsed.port or 11311
    # The master ipyros starts is this machine's alone: it, rosout, this session's node and the
    # basenodes it starts all listen on loopback (ROS binds to 127.0.0.1 when ROS_IP is a loopback
    # address, else to every interface, where anyone on the network could set parameters).
    os.environ.pop("ROS_HOSTNAME", None)  # it would win over ROS_IP
    os.environ["ROS_IP"] = LOOPBACK
    env = {**os.environ, "ROS_MASTER_URI": uri}
    handle = MasterHandle(uri, started=True)
    handle.processes.append(spawn(["rosmaster", "--core", "-p", str(port), "-w", "3"], env=env))
    deadline = time.monotonic() + timeout
    while not answers(uri, timeout=0.5):
        if handle.processes[0].poll() is not None or time.monotonic() > deadline:
            handle.stop()
            raise MasterError(f"could not start a ROS master on port {port} (is the port taken?); "
                              "set ROS_MASTER_URI to another port")
        time.sleep(0.05)
    # roscore's logger, for tools that read /rosout_agg (rospy's: Debian's C++ one listens everywhere)
    handle.processes.append(spawn([sys.executable, "-m", "ipyros.ros1.rosout"], env=env))
    os.environ["ROS_MASTER_URI"] = uri
    return handle
