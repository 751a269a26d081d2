"""The keeper: the one process of ipyros on a robot's own machine, which runs there what a session places on it.

A session on a laptop reaches the robot over Wi-Fi; the link is what fails most. So a guard that
must hold when the link is lost runs on the robot (``nd.guard(topic, ..., machine="robot1")``):
the session's writes go to the keeper, whose gate checks them and publishes them on the robot,
and whose stop process (:mod:`ipyros.processes.sentinel`, started on the robot) sends the stop
message on silence, on an e-stop, and for as long as the session is not heard (its *lease*).

Everything the keeper and a session say to each other goes over ROS, under one namespace of the
keeper's own (:func:`namespace`), as ``std_msgs/String`` texts:

====================================  =============================================================
topic (under ``/ipyros/machines/NAME``)  what
====================================  =============================================================
``info`` (latched)                    the keeper: its name, ROS, host, its start
                                      (``epoch``), the guards placed on it
``request``                           a session's request, signed with the machine's token
``reply``                             the keeper's answer, addressed to the request's sender and
                                      counter
``guards/ID/in``                      the session's messages for guard ``ID`` (the guarded type)
``guards/ID/beat``, ``beat2``, ...    the session's heartbeat for that guard, signed (the same beats on
                                      :data:`BEAT_LINES` topics: see there)
``guards/ID/state`` (latched)         what the guard does, as the session's ``%status`` shows it
``bases/ID/beat``, ...                the session's heartbeat for basenode ``ID``, signed
``bases/ID/state`` (latched)          the basenode's process: running, its pid, how it ended
====================================  =============================================================

A basenode placed on the machine (``baseNode(EXE).basePackage(PKG).machine("robot1")``) runs as the
keeper's child, found as rosrun finds it, and only from a package the keeper was started to allow
(``--allow PKG``): by its package and executable names, never a path, never a shell. It ends with
the keeper, and when its session is not heard for its grace.

A request is ``{"body": TEXT, "sig": HMAC}``: the HMAC-SHA256, under the token, of the body's exact
text, which names the keeper's ``epoch`` (a request for an earlier start of the keeper is refused),
its sender and a counter that only grows (a request replayed is refused). The token is a file made
at the keeper's first start (mode 0600); a session reads it from the same place (:func:`token_path`),
copied there by the user as an SSH key is. Nothing sent runs as code: a request names settings and
numbers, never a path, a shell line or source text.

This module is ROS-free; what subscribes and publishes is :class:`KeeperRos`, one small adapter a ROS
(``ipyros.ros1.machine``).
"""

from __future__ import annotations

import copy
import hashlib
import hmac
import json
import os
import re
import secrets
import signal
import socket
import stat
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Optional, Protocol

from ..core import msgtypes, names
from ..core.errors import DeclarationError, IpyrosError, first_line
from ..core.guard import Gate, check_rules, check_stop
from ..core.model import BaseModel
from .basenode import BaseProcess, exit_reason, log_dir
from .relayhost import RelayHost, Relaying
from .sentinel import Sentinel, Shared

__all__ = ["BEAT_LINES", "Keeper", "KeeperRos", "KeptBase", "KeptGuard", "Lease", "Lookup", "MachineError", "Outlet",
           "Refused", "Token", "Verifier", "beat_text", "beat_topics", "check_machine_name", "child_env", "log_line",
           "namespace",
           "serve", "token_path", "unknown_packages"]

#: A machine's name: a ROS name's word (it is part of the keeper's topics' names).
_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")

#: How long a placed guard's stop process may take to start on the robot (s).
GUARD_START = 30.0

#: How often the keeper looks at its leases (s): the stop follows a lost lease within this.
LOOK = 0.01

#: How often a guard's state is sent to its session when nothing changed (s): the session hears that the link holds.
REPORT = 0.2

#: On how many topics the session sends each heartbeat. On ROS 1 each topic is a TCP connection of its own: a lossy
#: link (Wi-Fi) that loses a beat's packet and then its retransmissions stalls one connection for longer than a
#: lease of 0.5 s about once a minute at 10 % loss (measured: a false stop); the same beat on three connections
#: keeps the lease unless all three stall at once. The keeper takes the first copy of each (the rest are replays).
#: On ROS 2 the beats go best effort: a reliable one lost held the later ones back until repaired (a false stop in
#: 20 s at 10 % loss, measured), and the keeper hears them in a participant of their own (``ros2/machine``).
BEAT_LINES = 3


def beat_topics(topics: str) -> list[str]:
    """The heartbeat's topics under a placed thing's ``topics``: ``beat``, ``beat2``, ``beat3``."""
    return [f"{topics}/beat"] + [f"{topics}/beat{k}" for k in range(2, BEAT_LINES + 1)]


class MachineError(IpyrosError):
    """A machine or its keeper cannot be used as asked (no token, no keeper of that name, a request refused)."""


class Refused(Exception):
    """The keeper refuses a request: the one line says why."""


def check_machine_name(name: Any) -> str:
    if not isinstance(name, str) or not _NAME.match(name):
        raise MachineError(f"machine name {name!r}: give a word of letters, digits and _ (e.g. robot1): it names the "
                           "keeper's topics")
    return name


def namespace(name: str) -> str:
    """Where a keeper's topics are."""
    return f"/ipyros/machines/{name}"


def token_path(name: str) -> Path:
    """Where the token of machine ``name`` is kept, on the robot and on the laptop alike."""
    home = os.environ.get("ROS_HOME") or str(Path.home() / ".ros")
    return Path(home) / "ipyros" / "machines" / f"{name}.token"


class Token:
    """A machine's secret: what signs a session's requests and heartbeats."""

    def __init__(self, secret: bytes) -> None:
        self._secret = secret

    @classmethod
    def made_or_read(cls, path: Path) -> "Token":
        """The keeper's: read, or made at its first start (a fresh secret, in a file only its owner reads)."""
        path.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
        try:
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        except FileExistsError:
            return cls.read(path, path.stem)
        with os.fdopen(fd, "w") as out:
            out.write(secrets.token_hex(32) + "\n")
        return cls.read(path, path.stem)

    @classmethod
    def read(cls, path: Path, machine: str) -> "Token":
        """A session's: the file copied from the robot; a one-line error when it is missing or others can read it."""
        try:
            mode = path.stat().st_mode
            text = path.read_text().strip()
        except FileNotFoundError:
            raise MachineError(f"no token for machine {machine} at {path}: copy it there from the robot's "
                               f"{path.name} (its keeper made it at its first start), mode 0600") from None
        except OSError as error:
            raise MachineError(f"the token of machine {machine} at {path} cannot be read ({error.strerror})") from None
        if mode & (stat.S_IRWXG | stat.S_IRWXO):
            raise MachineError(f"the token of machine {machine} at {path} can be read by others (mode "
                               f"{stat.S_IMODE(mode):04o}): chmod 600 {path}")
        if not re.fullmatch(r"[0-9a-f]{32,}", text):
            raise MachineError(f"{path} is not a machine's token (a line of hex digits): copy it again from the robot")
        return cls(bytes.fromhex(text))

    def sign(self, text: str) -> str:
        return hmac.new(self._secret, text.encode(), hashlib.sha256).hexdigest()

    def signed(self, body: dict[str, Any]) -> str:
        """A request as it is sent: its body's text and that text's signature."""
        text = json.dumps(body, sort_keys=True, separators=(",", ":"))
        return json.dumps({"body": text, "sig": self.sign(text)})


def beat_text(token: Token, epoch: str, sender: str, n: int) -> str:
    """A heartbeat: its sender, its counter, their signature (a beat recorded and played again keeps no lease)."""
    return f"{sender} {n} {token.sign(f'beat:{epoch}:{sender}:{n}')[:32]}"


class Verifier:
    """The keeper's check of what it hears: signed with its token, for this start of it, never heard before."""

    def __init__(self, token: Token, epoch: str) -> None:
        self._token, self.epoch = token, epoch
        self._last: dict[str, int] = {}  # by sender: the highest counter heard
        self._lock = threading.Lock()

    def open(self, text: str) -> dict[str, Any]:
        """The request's body, once its signature, start and counter hold; :class:`Refused` says why not."""
        try:
            outer = json.loads(text)
            body_text, sig = outer["body"], outer.get("sig")
            body = json.loads(body_text)
        except (ValueError, KeyError, TypeError):
            raise Refused("not a request of ipyros (a JSON body and its signature)") from None
        if not isinstance(body, dict):
            raise Refused("not a request of ipyros (its body is not a JSON object)")
        if not isinstance(sig, str) or not sig:
            raise Refused("unsigned request: a session signs with the machine's token")
        if not hmac.compare_digest(sig, self._token.sign(body_text)):
            raise Refused("bad signature: the sender does not hold this machine's token (copy the robot's token)")
        if body.get("epoch") != self.epoch:
            raise Refused("signed for another start of this keeper (a request replayed?): ask again")
        self._count(str(body.get("from")), body.get("n"))
        return body

    def beat(self, text: str) -> Optional[str]:
        """The sender of a valid heartbeat, or None (unsigned, forged, replayed)."""
        try:
            sender, n_text, sig = text.split(" ")
            n = int(n_text)
        except ValueError:
            return None
        if not hmac.compare_digest(sig, self._token.sign(f"beat:{self.epoch}:{sender}:{n}")[:32]):
            return None
        try:
            self._count("beat " + sender, n)
        except Refused:
            return None
        return sender

    def _count(self, sender: str, n: Any) -> None:
        if not isinstance(n, int):
            raise Refused("request without its counter")
        with self._lock:
            last = self._last.get(sender, -1)
            if n <= last:
                raise Refused(f"replayed request (counter {n}, already at {last})")
            self._last[sender] = n


@dataclass
class Lease:
    """How long the keeper waits for a session's heartbeat before it stops what that session placed (``length``),
    and before it ends it (``grace``; None: never), on the keeper's steady clock (s)."""

    length: float = 0.5
    grace: Optional[float] = 30.0
    last: float = field(default_factory=time.monotonic)
    #: Commands wait for the session to be heard: from the start until its first heartbeat (which may take a moment
    #: to find its way: a new subscription on ROS 2; :attr:`first`), and after the lease ran out (the stop message
    #: holds then).
    held: bool = True
    first: bool = True  # not heard yet

    def heard(self, now: float) -> Optional[float]:
        """A heartbeat came at ``now``; when it ends a hold, how long the session was silent."""
        silent = now - self.last if self.held else None
        self.last, self.held, self.first = now, False, False
        return silent

    def look(self, now: float) -> str:
        """"ok"; "lost" the first look past its length (the stop message from now on); "gone" past the grace."""
        silent = now - self.last
        if self.grace is not None and silent > self.grace:
            return "gone"
        if silent > self.length and not self.held:
            self.held = True
            return "lost"
        return "ok"


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
    def relay(self, source: str, target: str, type_name: str, gate: Any,
              complain: Callable[[str], None]) -> Relaying: ...
    def relay_host_command(self, name: str) -> list[str]: ...  # a relay host whose ROS node is ``name``


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


class KeptGuard:
    """A guard placed on this machine by a session: its gate in front of the robot's topic, its stop process, its
    lease."""

    def __init__(self, keeper: "Keeper", owner: str, gid: str, spec: dict[str, Any]) -> None:
        ros, ns = keeper.ros, keeper.ns
        self.owner, self.id, self._log = owner, gid, keeper.log
        self.topic, self.type = str(spec["topic"]), str(spec["type"])
        where = f"guard {self.topic}"
        try:
            cls = msgtypes.resolve_message(self.type)[1]
        except IpyrosError as error:
            raise Refused(f"{where}: {self.type} is not installed on this machine ({error})") from None
        try:
            limits, rates = check_rules(cls, spec.get("limits") or {}, spec.get("rate") or {},
                                        spec.get("on_limit", "clamp"),
                                        spec.get("timeout"), spec.get("grace", 3.0), spec.get("repeat", 10.0), where)
            self._stop = ros.deserialize(cls, bytes.fromhex(str(spec["stop"])))
            check_stop(cls, self._stop, limits, where, given=True)
        except (DeclarationError, ValueError) as error:
            raise Refused(str(error)) from None
        self.lease = Lease(float(spec.get("lease", 0.5)), spec.get("grace_lease", 30.0), keeper.clock())
        self.shared = Shared.create()
        #: Why its stop process is gone, if it ended on its own: the guard then fails closed (see :meth:`tend`).
        self.lost: Optional[str] = None
        self._stopped_at = -float("inf")  # when the keeper last sent the stop message for a lost process
        self.repeat = float(spec.get("repeat", 10.0))
        self.gate = Gate(self.topic, cls, limits, rates, str(spec.get("on_limit", "clamp")), self.stop_message,
                         self.holding, self.shared.passed, lambda text: self._log(f"{where}: {text}"))
        self._out = ros.publisher(self.topic, self.type, bool(spec.get("latch")))
        self._settings = {"node": f"ipyros_machine_{keeper.name}_guard_{gid}", "topic": self.topic,
                          "type": self.type, "latch": bool(spec.get("latch")), "estop_topic": spec.get("estop_topic"),
                          "timeout": spec.get("timeout"), "repeat": self.repeat,
                          "grace": float(spec.get("grace", 3.0)), "stop": str(spec["stop"])}
        self.log_path = log_dir() / f"machine_{keeper.name}_guard_{gid}.log"
        self._command = ros.sentinel_command()
        self.sentinel: Optional[Sentinel] = None
        try:
            self._start_sentinel()
        except Refused:
            self._out.close()
            self.shared.close()
            raise
        self._reporter = Reporter(ros, f"{ns}/guards/{gid}/state")
        self._subs = [ros.subscribe(f"{ns}/guards/{gid}/in", self.type, self.command, lossy=bool(spec.get("lossy"))),
                      *(ros.subscribe(topic, "std_msgs/String", keeper.beat, lossy=True)
                        for topic in beat_topics(f"{ns}/guards/{gid}"))]

    def _start_sentinel(self) -> None:
        self.shared.ready = False
        sentinel = Sentinel(self._command, self._settings, self.shared, self.log_path, child_env())
        problem = sentinel.ready(GUARD_START)
        if problem is not None:
            raise Refused(f"guard {self.topic}: its stop process could not start on this machine ({problem}; see "
                          f"{self.log_path})")
        self.sentinel = sentinel

    def stop_message(self) -> Any:
        return copy.deepcopy(self._stop)

    def holding(self) -> bool:
        """Whether the stop message goes in place of every command: e-stopped, the session not heard (since its lease
        ran out, or not yet: its first heartbeat may come after its first command), or its stop process lost."""
        return self.shared.estopped or self.lost is not None or self.lease.first

    def command(self, msg: Any) -> None:
        """A message from the session: through the gate, onto the robot's topic."""
        try:
            send = self.gate.check(msg).send
        except Exception as error:  # noqa: BLE001 - a bad message never ends the keeper; when in doubt, stop
            self._log(f"guard {self.topic}: a message from the session could not be checked ({error}): the stop "
                      "message goes in its place")
            send = self.stop_message()
        if send is not None:
            try:
                self._out.write(send)
            except Exception as error:  # noqa: BLE001 - as above: the next command or the stop process follows
                self._log(f"guard {self.topic}: a command could not be sent ({error})")

    def hold(self, on: bool) -> None:
        """The lease ran out (``on``) or the session is heard again: the stop message holds, or commands pass."""
        self.shared.held = on
        self._wake()

    def estop(self, on: bool) -> None:
        """E-stop (``on``) or release; a release starts its stop process again if it was lost (refused in one line
        if it cannot: the stop message holds)."""
        self.shared.estop_session = on
        if not on and self.lost is not None:
            if self.sentinel is not None:
                self.sentinel.end(hold=False)  # gone already: its pipe closed, its exit status read
                self.sentinel = None
            self._start_sentinel()
            self.lost = None
        self._wake()

    def tend(self, now: float) -> Optional[str]:
        """While the stop message holds (the session not heard, e-stopped, its stop process lost), the keeper sends
        it too, at the guard's rate, on the publisher the robot already hears commands from (a stop process just
        started may not have been found by the robot's subscribers yet: on ROS 2 that takes a moment). When the stop
        process ended on its own (killed, crashed): one line the first time, and every command is replaced by the
        stop message until the session releases it."""
        said = None
        if self.lost is None:
            sentinel = self.sentinel
            if sentinel is not None and not sentinel.running:
                code = sentinel.returncode
                self.lost = f"killed by signal {-code}" if code is not None and code < 0 else f"exit code {code}"
                said = (f"guard {self.topic}: its stop process ended ({self.lost}; its log: {self.log_path}): the "
                        "keeper sends the stop message in place of every command until the session releases it")
        if (self.shared.estopped or self.lost is not None) and now - self._stopped_at >= 1.0 / self.repeat:
            self._stopped_at = now
            self._out.write(self.stop_message())
            if self.lost is not None:  # a stop process counts its own
                self.shared.stops_sent += 1
        return said

    def _wake(self) -> None:
        if self.sentinel is not None:
            try:
                self.sentinel.tell({"wake": True})
            except OSError:
                pass

    def state(self) -> dict[str, Any]:
        shared, figures = self.shared, self.gate.figures
        alive = self.sentinel is not None and self.sentinel.running
        return {"id": self.id, "topic": self.topic, "state": shared.state, "held": bool(shared.held), "lost": self.lost,
                "heard": not self.lease.first,
                "estop_session": shared.estop_session, "estop_topic": shared.estop_topic, "alive": alive,
                "stops": shared.stops_sent, "reach": shared.reach, "commands": self.gate.commands,
                "figures": [figures.passed, figures.clamped, figures.dropped, figures.replaced, figures.last_trip]}

    def report(self, now: float, every: float = REPORT) -> None:
        self._reporter.report(self.state(), now, every, steady=("figures",))

    def close(self, hold: bool) -> None:
        """End it: its stop process holds the stop message for its grace first (``hold``), or quits at once."""
        for sub in self._subs:
            sub.close()
        if self.sentinel is not None:
            self.sentinel.end(hold=hold, wait=False)
            self.sentinel = None
        self._out.close()
        self._reporter.close()


@dataclass
class KeptRelay:
    id: str
    what: str  # "relay SOURCE -> TARGET"
    kind: str  # "topic", "service", "action"
    type: str
    source: str
    target: str
    relay: Optional[Relaying] = None  # in the keeper, through a guard's gate; None: in the relays' own process


class KeptRelays:
    """The topic relays of one session's placed wrapping node (one link for them all): run on this machine, beside
    its basenode, so that its topics cross the link once (to a handler in the session) or not at all. They run in a
    process of their own (:mod:`ipyros.processes.relayhost`: the leases' watch shares nothing with a camera's
    images), except a relay onto a topic a guard stands on here: that one runs in the keeper, through the guard's
    gate (see :meth:`Keeper.gate_relays`). They end when the session asks, or when it is silent past the grace
    (None: they are left running, as its basenode is)."""

    def __init__(self, keeper: "Keeper", owner: str, lid: str, grace: Any) -> None:
        if grace is not None and (not isinstance(grace, (int, float)) or isinstance(grace, bool) or grace <= 0):
            raise Refused(f"relays: grace={grace!r}: give the seconds (> 0), or None to keep them")
        self.owner, self.id, self._keeper = owner, lid, keeper
        self.lease = Lease(float("inf"), grace, keeper.clock())
        self.relays: dict[str, KeptRelay] = {}
        self._host: Optional[RelayHost] = None
        self._reporter = Reporter(keeper.ros, f"{keeper.ns}/relays/{lid}/state")
        self._beats = [keeper.ros.subscribe(topic, "std_msgs/String", keeper.beat, lossy=True)
                       for topic in beat_topics(f"{keeper.ns}/relays/{lid}")]

    def _hosted(self) -> RelayHost:
        """Its relay host, started at its first relay."""
        if self._host is None or self._host.ended is not None:
            keeper = self._keeper
            name = f"ipyros_machine_{keeper.name}_relays_{self.id}"
            try:
                self._host = RelayHost(keeper.ros.relay_host_command(name), log_dir() / f"{name}.log",
                                       lambda text: keeper.log(f"relays of {self.owner}: {text}"), child_env())
            except IpyrosError as error:
                raise Refused(str(error)) from None
            keeper.log(f"relays of {self.owner}: their process runs (pid {self._host.pid})")
        return self._host

    def add(self, rid: str, spec: dict[str, Any], gate: Any) -> str:
        """Open relay ``rid`` (``source``, ``target``, ``type``), its first message through ``gate``; what it is."""
        if rid in self.relays:
            raise Refused(f"relay {rid} runs already")
        kind, source, target, type_name = (str(spec.get(key, "topic")) for key in ("kind", "source", "target", "type"))
        if kind not in ("topic", "service", "action"):
            raise Refused(f"relay: kind {kind!r:.40}: give topic, service or action")
        for end in (source, target):
            if not end.startswith("/") or not names.is_legal_name(end):
                raise Refused(f"relay: {kind} {end!r:.80}: give a global ROS name")
        if not _TYPE.match(type_name):
            raise Refused(f"relay: type {type_name!r:.80}: give a {kind}'s type, package/Type")
        what = f"relay {source} -> {target}" if kind == "topic" else f"{kind} relay {source} -> {target}"
        kept = KeptRelay(rid, what, kind, type_name, source, target)
        self._open(kept, gate)
        self.relays[rid] = kept
        return kept.what

    def _open(self, kept: KeptRelay, gate: Any) -> None:
        try:
            if gate is None or kept.kind != "topic":  # a guard stands on topics only
                self._hosted().ask("add", rid=kept.id, kind=kept.kind, source=kept.source, target=kept.target,
                                   type=kept.type)
                kept.relay = None
            else:
                keeper = self._keeper
                kept.relay = keeper.ros.relay(kept.source, kept.target, kept.type, gate,
                                              lambda text: keeper.log(f"{kept.what} of {self.owner}: {text}"))
        except Exception as error:  # noqa: BLE001 - the ROS adapter's or the host's complaint, made one line
            raise Refused(f"{kept.what}: {first_line(error)}") from None

    def _close_one(self, kept: KeptRelay) -> None:
        if kept.relay is not None:
            kept.relay.close()
        elif self._host is not None and self._host.ended is None:
            try:
                self._host.ask("remove", rid=kept.id)
            except IpyrosError as error:
                self._keeper.log(f"{kept.what} of {self.owner}: {error}")

    def remove(self, rid: str) -> Optional[KeptRelay]:
        kept = self.relays.pop(rid, None)
        if kept is not None:
            self._close_one(kept)
        return kept

    def set_gate(self, topic: str, gate: Any) -> None:
        """The guard on ``topic`` here changed: each relay onto it passes its gate from now on (moved into the keeper,
        closed first: nothing passes unchecked meanwhile), or none (moved back to the relays' process)."""
        for kept in list(self.relays.values()):
            if kept.target != topic or kept.kind != "topic":
                continue
            if kept.relay is not None and gate is not None:
                kept.relay.gate = gate
                continue
            if (kept.relay is None) == (gate is None):
                continue
            self._close_one(kept)
            try:
                self._open(kept, gate)
            except Refused as why:
                self.relays.pop(kept.id, None)
                self._keeper.log(f"{kept.what} of {self.owner} ended: {why}")

    def send(self, rid: str, data: bytes) -> None:
        """A message of the session's (serialized) onto relay ``rid``'s target, through its gate if it has one."""
        kept = self.relays.get(rid)
        if kept is None or kept.kind != "topic":
            raise Refused(f"no topic relay {rid} of this session here")
        try:
            if kept.relay is not None:
                kept.relay.send(self._keeper.ros.deserialize(msgtypes.resolve_message(kept.type)[1], data))
            else:
                self._hosted().ask("send", rid=rid, data=data.hex())
        except (IpyrosError, ValueError) as error:
            raise Refused(f"{kept.what}: the message could not be sent as {kept.type} ({first_line(error)})") from None

    def state(self) -> dict[str, Any]:
        hosted = self._host.figures if self._host is not None else {}
        relays = {}
        for rid, kept in list(self.relays.items()):
            if kept.relay is not None:
                f = kept.relay.figures()
                relays[rid] = [f.messages, f.connections, f.dropped]
            else:
                relays[rid] = hosted.get(rid, [0, 0, 0])
        ended = self._host.ended if self._host is not None else None
        return {"id": self.id, "relays": relays, "ended": ended}

    def report(self, now: float, every: float = REPORT) -> None:
        if self._reporter.due(now, every):  # only figures change: no look at them between reports
            self._reporter.report(self.state(), now, every)

    def close(self) -> None:
        for sub in self._beats:
            sub.close()
        for kept in self.relays.values():
            if kept.relay is not None:
                kept.relay.close()
        self.relays = {}
        if self._host is not None:
            self._host.close()  # its relays end with it
            self._host = None
        self._reporter.close()


def child_env() -> dict[str, str]:
    """The environment of a process the keeper starts from this package (a stop process, a relay host): ipyros
    importable as it is here."""
    env = dict(os.environ)
    package_root = str(Path(__file__).resolve().parents[2])
    env["PYTHONPATH"] = os.pathsep.join(p for p in (package_root, env.get("PYTHONPATH")) if p)
    return env


#: A message, service or action type as a relay's request may name it.
_TYPE = re.compile(r"^[A-Za-z][A-Za-z0-9_]*/((msg|srv|action)/)?[A-Za-z][A-Za-z0-9_]*$")

#: An executable as a placed basenode's request may name it: a name in its package, never a path or a shell line.
_EXECUTABLE = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.+-]{0,127}$")

#: The most arguments, and the longest, a placed basenode's request may give it.
_MOST_ARGS, _LONGEST_ARG = 64, 4096


class KeptBase:
    """A basenode placed on this machine by a session: its process, the keeper's child (it ends with the keeper),
    and its session's lease (past its grace, the keeper stops it; grace None: it is left running)."""

    def __init__(self, keeper: "Keeper", owner: str, bid: str, spec: dict[str, Any]) -> None:
        self.owner, self.id, self._log = owner, bid, keeper.log
        base = _base_of(spec, keeper.allowed)
        self.what = base.describe()
        try:
            argv = keeper.ros.basenode_command(base)
        except IpyrosError as error:
            raise Refused(str(error)) from None
        grace = spec.get("grace", 30.0)
        if grace is not None and (not isinstance(grace, (int, float)) or isinstance(grace, bool) or grace <= 0):
            raise Refused(f"basenode {self.what}: grace={grace!r}: give the seconds (> 0), or None to keep it")
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


class Keeper:
    """The keeper's work, whatever its ROS: requests checked and done, leases watched, the state reported."""

    def __init__(self, name: str, token: Token, ros: KeeperRos, log: Callable[[str], None],
                 clock: Callable[[], float] = time.monotonic, allowed: frozenset[str] = frozenset()) -> None:
        self.name, self.ros, self.log, self.clock = check_machine_name(name), ros, log, clock
        self.allowed = allowed
        self._allows = {package: sorted(ros.executables(package)) for package in sorted(allowed)}  # sessions' TAB
        self.ns = namespace(name)
        self.epoch = secrets.token_hex(8)
        self._verifier = Verifier(token, self.epoch)
        self.guards: dict[str, KeptGuard] = {}
        self.bases: dict[str, KeptBase] = {}
        self.relays: dict[str, KeptRelays] = {}
        self._lock = threading.RLock()
        self._ended = threading.Event()
        self._info = ros.publisher(f"{self.ns}/info", "std_msgs/String", True)
        self._reply = ros.publisher(f"{self.ns}/reply", "std_msgs/String", False)
        self._request_sub = ros.subscribe(f"{self.ns}/request", "std_msgs/String", self.request)
        self._publish_info()

    def ready_line(self) -> str:
        allows = f"the basenodes of {', '.join(sorted(self.allowed))}" if self.allowed else \
            "no basenodes (--allow PACKAGE)"
        return (f"ipyros machine {self.name} ready on {self.ros.name} at {self.ros.address()} (host "
                f"{socket.gethostname()}, pid {os.getpid()}): it keeps the guards sessions place on it, and "
                f"{allows}")

    def _publish_info(self) -> None:
        with self._lock:
            guards = [{"id": g.id, "topic": g.topic, "owner": g.owner} for g in self.guards.values()]
            bases = [{"id": b.id, "base": b.what, "owner": b.owner} for b in self.bases.values()]
        info = {"name": self.name, "ros": self.ros.name, "host": socket.gethostname(), "pid": os.getpid(),
                "address": self.ros.address(), "epoch": self.epoch, "allows": self._allows,
                "guards": guards, "bases": bases}
        self._info.write(self.ros.text(json.dumps(info)))

    # -- requests ---------------------------------------------------------------------------------
    def request(self, msg: Any) -> None:
        text = msg.data
        if self._pinged(text):
            return
        try:
            addressed = json.loads(json.loads(text)["body"])  # who to answer, before it is checked
            sender, n = str(addressed.get("from")), addressed.get("n")
        except (ValueError, KeyError, TypeError, AttributeError):
            sender, n = "?", None
        try:
            body = self._verifier.open(text)
            op = body.get("op")
            act = {"place": self._place, "estop": self._estop, "remove": self._remove, "start_base": self._start_base,
                   "stop_base": self._stop_base, "restart_base": self._restart_base,
                   "tail_base": self._tail_base, "relay": self._relay, "unrelay": self._unrelay,
                   "relay_send": self._relay_send}.get(str(op))
            if act is None:
                raise Refused(f"unknown request {op!r}")
            answer = act(body)
        except Refused as why:
            self.log(f"refused a request of {sender}: {why}")
            self._answer(sender, n, {"ok": False, "error": str(why)})
            return
        except Exception as error:  # noqa: BLE001 - a request never ends the keeper
            self.log(f"a request of {sender} failed: {error!r}")
            self._answer(sender, n, {"ok": False, "error": f"the keeper failed: {error}"})
            return
        self._answer(sender, n, {"ok": True, **answer})

    def _pinged(self, text: str) -> bool:
        """A ping (``{"ping": {"from": S, "n": N}}``, unsigned: anyone on the graph may see the keeper and time the
        link to it) is answered at once with a pong, and does nothing else."""
        if not text.startswith('{"ping"'):
            return False
        try:
            ping = json.loads(text)["ping"]
            sender, n = str(ping["from"])[:40], int(ping["n"])
        except (ValueError, KeyError, TypeError):
            return True
        self._answer(sender, n, {"pong": True})
        return True

    def _answer(self, sender: str, n: Any, fields: dict[str, Any]) -> None:
        self._reply.write(self.ros.text(json.dumps({"to": sender, "n": n, **fields})))

    def _place(self, body: dict[str, Any]) -> dict[str, Any]:
        gid = _checked_id(body, "guard")
        with self._lock:
            old = self.guards.get(gid)
            if old is not None and old.owner != body["from"]:
                raise Refused(f"guard {gid} belongs to another session")
        # Placed again (new rules): the new one first; the old one keeps the robot until it stands (a refusal
        # leaves it as it was), then quits.
        guard = KeptGuard(self, str(body["from"]), gid, dict(body.get("guard") or {}))
        with self._lock:
            self.guards[gid] = guard
        self.gate_relays(guard.topic)
        if old is not None:
            old.close(hold=False)
        self.log(f"placed guard {guard.topic} for {guard.owner} (lease {guard.lease.length:g} s, grace "
                 f"{guard.lease.grace} s)")
        self._publish_info()
        guard.report(self.clock(), every=0.0)
        return {"id": gid}

    def _guard_of(self, body: dict[str, Any]) -> KeptGuard:
        with self._lock:
            guard = self.guards.get(str(body.get("id")))
        if guard is None or guard.owner != body["from"]:
            raise Refused(f"no guard {body.get('id')} of this session here")
        return guard

    def _estop(self, body: dict[str, Any]) -> dict[str, Any]:
        guard = self._guard_of(body)
        guard.estop(bool(body.get("on")))
        self.log(f"guard {guard.topic}: {'e-stopped' if body.get('on') else 'released'} by {guard.owner}")
        return {}

    def _remove(self, body: dict[str, Any]) -> dict[str, Any]:
        guard = self._guard_of(body)
        with self._lock:
            self.guards.pop(guard.id, None)
        self.gate_relays(guard.topic)
        guard.close(hold=bool(body.get("hold")))
        self.log(f"guard {guard.topic} of {guard.owner} removed" + (" (its stop message holds for its grace)"
                                                                      if body.get("hold") else ""))
        self._publish_info()
        return {}

    # -- basenodes ---------------------------------------------------------------------------------
    def _start_base(self, body: dict[str, Any]) -> dict[str, Any]:
        bid = _checked_id(body, "basenode")
        with self._lock:
            if bid in self.bases:
                raise Refused(f"basenode {bid} runs already")
        base = KeptBase(self, str(body["from"]), bid, dict(body.get("base") or {}))
        with self._lock:
            self.bases[bid] = base
        self.log(f"started basenode {base.what} for {base.owner} (pid {base.process.pid}, grace "
                 f"{base.lease.grace} s)")
        self._publish_info()
        base.report(self.clock(), every=0.0)
        return {"id": bid, "pid": base.process.pid}

    def _base_of(self, body: dict[str, Any]) -> KeptBase:
        with self._lock:
            base = self.bases.get(str(body.get("id")))
        if base is None or base.owner != body["from"]:
            raise Refused(f"no basenode {body.get('id')} of this session here")
        return base

    def _stop_base(self, body: dict[str, Any]) -> dict[str, Any]:
        base = self._base_of(body)
        with self._lock:
            self.bases.pop(base.id, None)
        base.close()
        self.log(f"stopped basenode {base.what} of {base.owner}")
        self._publish_info()
        return {"returncode": base.process.returncode}

    def _restart_base(self, body: dict[str, Any]) -> dict[str, Any]:
        base = self._base_of(body)
        try:
            base.process.restart()
            base.ended = False
        except IpyrosError as error:
            raise Refused(f"basenode {base.what}: {error}") from None
        self.log(f"restarted basenode {base.what} for {base.owner} (pid {base.process.pid})")
        base.report(self.clock(), every=0.0)
        return {"pid": base.process.pid}

    def _tail_base(self, body: dict[str, Any]) -> dict[str, Any]:
        n = body.get("lines", 20)
        return {"lines": self._base_of(body).process.tail(n if isinstance(n, int) and 0 < n <= 1000 else 20)}

    # -- relays ---------------------------------------------------------------------------------------
    def guard_on(self, topic: str) -> Optional[KeptGuard]:
        """The guard that stands on ``topic`` here, if one does (what a relay onto it must pass)."""
        with self._lock:
            return next((g for g in self.guards.values() if g.topic == topic), None)

    def gate_relays(self, topic: str) -> None:
        """Hand each relay onto ``topic`` the gate of the guard that stands on it now (or none): a guard placed,
        placed again with new rules, or removed by its session."""
        guard = self.guard_on(topic)
        with self._lock:
            groups = list(self.relays.values())
        for group in groups:
            group.set_gate(topic, guard.gate if guard is not None else None)

    def _unguarded(self, topic: str) -> None:
        """A guard ended past its session's grace: what its relays sent through it would reach the robot unchecked
        from now on; they end instead (the safe way: nothing on the topic but what others send)."""
        with self._lock:
            if self.guard_on(topic) is not None:
                return
            groups = list(self.relays.values())
        for group in groups:
            for kept in list(group.relays.values()):
                if kept.target == topic:
                    group.remove(kept.id)
                    self.log(f"{kept.what} of {group.owner} ended with its guard")

    def _relay(self, body: dict[str, Any]) -> dict[str, Any]:
        lid, rid = _checked_id(body, "relays"), _checked_id({"id": body.get("rid")}, "relay")
        with self._lock:
            group = self.relays.get(lid)
            if group is not None and group.owner != body["from"]:
                raise Refused(f"relays {lid} belong to another session")
        if group is None:
            group = KeptRelays(self, str(body["from"]), lid, body.get("grace", 30.0))
            with self._lock:
                self.relays[lid] = group
        spec = dict(body.get("relay") or {})
        guard = self.guard_on(str(spec.get("target")))  # its gate from the relay's first message on
        try:
            what = group.add(rid, spec, guard.gate if guard is not None else None)
        except Refused:
            if not group.relays:
                with self._lock:
                    self.relays.pop(lid, None)
                group.close()
            raise
        if self.guard_on(str(spec.get("target"))) is not guard:  # one placed or removed meanwhile (its grace)
            self.gate_relays(str(spec.get("target")))
        self.log(f"{what} for {group.owner}" + (" (through its guard)" if guard is not None else ""))
        group.report(self.clock(), every=0.0)
        return {"rid": rid}

    def _relays_of(self, body: dict[str, Any]) -> KeptRelays:
        with self._lock:
            group = self.relays.get(str(body.get("id")))
        if group is None or group.owner != body["from"]:
            raise Refused(f"no relays {body.get('id')} of this session here")
        return group

    def _unrelay(self, body: dict[str, Any]) -> dict[str, Any]:
        group = self._relays_of(body)
        found = group.remove(str(body.get("rid")))
        if not group.relays:
            with self._lock:
                self.relays.pop(group.id, None)
        if found is not None:
            self.log(f"{found.what} of {group.owner} removed")
        if not group.relays:
            group.close()
        else:
            group.report(self.clock(), every=0.0)
        return {}

    def _relay_send(self, body: dict[str, Any]) -> dict[str, Any]:
        """A message of the session's onto a relayed topic (``%pub``, an e-stop's stop message): through its gate."""
        try:
            data = bytes.fromhex(str(body.get("data")))
        except ValueError:
            raise Refused("relay_send: data must be the message's serialized bytes, in hex") from None
        self._relays_of(body).send(str(body.get("rid")), data)
        return {}

    def beat(self, msg: Any) -> None:
        sender = self._verifier.beat(msg.data)
        if sender is None:
            return
        now = self.clock()
        with self._lock:
            guards = [g for g in self.guards.values() if g.owner == sender]
            for base in self.bases.values():
                if base.owner == sender:
                    base.lease.heard(now)
            for group in self.relays.values():
                if group.owner == sender:
                    group.lease.heard(now)
        for guard in guards:
            first = guard.lease.first
            silent = guard.lease.heard(now)
            if silent is not None:
                guard.hold(False)
                heard = f"first after {silent:.2f} s: commands pass" if first else \
                    f"again after {silent:.2f} s: commands pass again"
                self.log(f"guard {guard.topic}: {sender} heard {heard}")

    # -- the watch --------------------------------------------------------------------------------
    def look(self) -> None:
        """One look at the leases (the stop message when one ran out; the guard ended past its grace) and reports."""
        now = self.clock()
        with self._lock:
            guards = list(self.guards.values())
        for guard in guards:
            seen = guard.lease.look(now)
            if seen == "lost":
                guard.hold(True)
                self.log(f"guard {guard.topic}: nothing heard from {guard.owner} for {guard.lease.length:g} s: the "
                         f"stop message holds until it is heard again")
            elif seen == "gone":
                with self._lock:
                    self.guards.pop(guard.id, None)
                self._unguarded(guard.topic)
                guard.close(hold=True)
                self.log(f"guard {guard.topic}: {guard.owner} silent past its grace ({guard.lease.grace:g} s): "
                         f"the guard ends, its stop message held for its own grace")
                self._publish_info()
                continue
            try:
                said = guard.tend(now)
                if said:
                    self.log(said)
            except Exception as error:  # noqa: BLE001 - the next look sends it again
                self.log(f"guard {guard.topic}: the keeper could not send the stop message ({error!r})")
            try:
                guard.report(now)
            except Exception as error:  # noqa: BLE001 - a report lost never keeps the other leases from their look
                self.log(f"guard {guard.topic}: its state could not be reported ({error!r})")

    def _look_at_bases(self, now: float) -> None:
        with self._lock:
            bases = list(self.bases.values())
        for base in bases:
            if base.lease.look(now) == "gone":
                with self._lock:
                    self.bases.pop(base.id, None)
                base.close()
                self.log(f"basenode {base.what}: {base.owner} silent past its grace ({base.lease.grace:g} s): "
                         "stopped")
                self._publish_info()
                continue
            try:
                base.report(now)
            except Exception as error:  # noqa: BLE001 - as a guard's
                self.log(f"basenode {base.what}: its state could not be reported ({error!r})")

    def _look_at_relays(self, now: float) -> None:
        with self._lock:
            groups = list(self.relays.values())
        for group in groups:
            if group.lease.look(now) == "gone":
                with self._lock:
                    self.relays.pop(group.id, None)
                group.close()
                self.log(f"relays of {group.owner}: silent past its grace ({group.lease.grace:g} s): ended")
                continue
            try:
                group.report(now)
            except Exception as error:  # noqa: BLE001 - as a guard's
                self.log(f"relays of {group.owner}: their state could not be reported ({error!r})")

    def run(self) -> None:
        """Watch until :meth:`end`. A look that fails is logged and the next one comes: the leases are never left
        unwatched."""
        while not self._ended.wait(LOOK):
            try:
                self.look()
                self._look_at_bases(self.clock())
                self._look_at_relays(self.clock())
            except Exception as error:  # noqa: BLE001 - see the docstring
                self.log(f"a look at the leases failed ({error!r}); looking again")

    def end(self) -> None:
        """The keeper stops: every guard holds its stop message for its grace (its process outlives the keeper), every
        basenode placed on it is stopped (one killed with the keeper gets SIGTERM from the kernel: no orphans)."""
        if self._ended.is_set():
            return
        self._ended.set()
        self._request_sub.close()
        with self._lock:
            guards, self.guards = list(self.guards.values()), {}
            bases, self.bases = list(self.bases.values()), {}
            groups, self.relays = list(self.relays.values()), {}
        for group in groups:  # first: nothing relayed onto a guarded topic once its guard holds the stop message
            group.close()
        for guard in guards:
            guard.close(hold=True)
        for base in bases:
            base.close()


def log_line(text: str) -> None:
    """The keeper's log: a line on its standard output, with the time."""
    print(f"{time.strftime('%H:%M:%S')} {text}", flush=True)


def unknown_packages(ros: KeeperRos, allowed: frozenset[str], where: str) -> Optional[str]:
    """The one line for ``--allow`` packages this machine does not have (``where``: where its ROS looks), if any."""
    missing = sorted(p for p in allowed if not ros.has_package(p))
    return (f"ipyros machine: --allow {' '.join(missing)}: no such package in {where}; give the packages whose "
            "nodes sessions may start here") if missing else None


def serve(keeper: Keeper) -> None:
    """Run ``keeper`` in this process until SIGTERM or Ctrl-C: its ready line, then its watch; ended on the way out
    whatever ends it."""
    signal.signal(signal.SIGTERM, lambda *_: keeper.end())
    signal.signal(signal.SIGINT, lambda *_: keeper.end())
    print(keeper.ready_line(), flush=True)
    try:
        keeper.run()
    finally:
        keeper.end()


def _checked_id(body: dict[str, Any], what: str) -> str:
    found = str(body.get("id", ""))
    if not re.fullmatch(r"[a-z0-9]{6,32}", found):
        raise Refused(f"{what} id {found!r:.40}: give 6 to 32 lowercase letters and digits")
    return found
