"""Find the ROS master, or start one on localhost when none answers.

A roboticist at a prompt should not have to open another terminal for ``roscore``:
if nothing answers at ``ROS_MASTER_URI`` (default ``http://localhost:11311``), ipyros
starts ``rosmaster --core`` (and ``rosout``) there itself, says so, and stops it when
the session ends. If a master answers it is used as it is.
"""

from __future__ import annotations

import os
import shutil
import socket
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


def is_this_host(uri: str) -> bool:
    """Whether ``uri`` names this machine: a loopback name or address, its host name, or an address of one of its
    interfaces (one this process can bind to: the kernel's own answer, with no list of interfaces to read)."""
    host = urlparse(uri).hostname or ""
    if _loopback(host) or host == os.uname().nodename:
        return True
    try:
        addresses = {info[4][0] for info in socket.getaddrinfo(host, None, socket.AF_INET)}
    except OSError:
        return False
    for address in addresses:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            try:
                probe.bind((address, 0))
                return True
            except OSError:
                continue
    return False


def _loopback(host: str) -> bool:
    return host == "localhost" or host.startswith("127.") or host == "::1"


def address_towards(uri: str) -> Optional[str]:
    """This machine's address on the way to ``uri``'s host (what peers there can call back), if there is a route."""
    parsed = urlparse(uri)
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            probe.connect((parsed.hostname or "", parsed.port or 11311))  # UDP: nothing is sent, a route is chosen
            return probe.getsockname()[0]
    except OSError:
        return None


def callback_advice(uri: str) -> Optional[str]:
    """One line when the master is on another machine and nothing says how its peers reach this one, else None.

    A ROS 1 node gives the master a URI to call back at: ``ROS_IP``, else ``ROS_HOSTNAME``, else
    this machine's host name, which the other machine often cannot resolve (then topics
    connect in one direction only, and nothing says why).
    """
    if is_this_host(uri) or os.environ.get("ROS_IP") or os.environ.get("ROS_HOSTNAME"):
        return None
    mine = address_towards(uri)
    example = f"export ROS_IP={mine}" if mine else "export ROS_IP=<this machine's address on that network>"
    return (f"ipyros: the master {uri} is on another machine and neither ROS_IP nor ROS_HOSTNAME is set: its peers "
            f"will call this session back at '{os.uname().nodename}', which they may not resolve; before starting "
            f"ipyros: {example}")


@dataclass
class MasterHandle:
    """The master this session uses; ``process`` is set when ipyros started it."""

    uri: str
    started: bool
    processes: list[subprocess.Popen] = field(default_factory=list)
    local_only: bool = True  # a master ipyros started at a loopback address listens there only

    def describe(self) -> str:
        where = "local: listening on 127.0.0.1 only" if self.local_only else \
            f"listening on this machine's network ({os.environ.get('ROS_IP')}) for the robot's other machines"
        how = f"started by ipyros, {where}; it stops when this session exits" if self.started else "found running"
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
    if not is_this_host(uri):
        raise MasterError(f"no ROS master answers at {uri}, on another machine, and ipyros can start one only on "
                          "this one; start roscore there, or point ROS_MASTER_URI at this machine")
    if shutil.which("rosmaster") is None:
        raise MasterError("no ROS master answers and 'rosmaster' is not installed; "
                          "apt-get install python3-rosmaster (or run: bash run.sh)")
    port = parsed.port or 11311
    host = parsed.hostname or LOOPBACK
    # A master at a loopback name is this machine's alone: it, rosout, this session's node and the
    # basenodes it starts all listen on loopback (ROS binds to 127.0.0.1 when ROS_IP is a loopback
    # address, else to every interface, where anyone on the network could set parameters). One
    # at this machine's network address is meant for the robot's other machines: peers are told
    # that address (ROS_IP), and it listens where they can reach it.
    loopback = _loopback(host)
    os.environ.pop("ROS_HOSTNAME", None)  # it would win over ROS_IP
    os.environ["ROS_IP"] = LOOPBACK if loopback else (address_towards(uri) or host)
    env = {**os.environ, "ROS_MASTER_URI": uri}
    handle = MasterHandle(uri, started=True, local_only=loopback)
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
