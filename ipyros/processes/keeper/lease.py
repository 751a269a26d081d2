"""The keeper's trust and time: the machine's token, signed requests and heartbeats, the lease.

A session proves itself to a keeper with the machine's token (:class:`Token`: an HMAC key in a file of
mode 0600, copied to the laptop as an SSH key is): each request and heartbeat is signed, names the
keeper's start (its ``epoch``) and a counter that only grows, so that a replay or a forgery is refused
(:class:`Verifier`). The :class:`Lease` says, on the keeper's steady clock, when a silent session's
guards hold the stop message and when its placed things end.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import os
import re
import secrets
import stat
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional

from ...core import names
from ...core.errors import IpyrosError

__all__ = ["checked_grace", "BEAT_LINES", "Lease", "MachineError", "Refused", "Token", "Verifier", "beat_text", "beat_topics", "check_machine_name", "namespace", "token_path"]

#: A machine's name: a ROS name's word (it is part of the keeper's topics' names).
_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")

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


def checked_grace(grace: Any, what: str) -> Optional[float]:
    """A placed thing's grace as a request gives it: seconds (> 0), or None to keep it; else refused in one line."""
    if grace is not None and (not isinstance(grace, (int, float)) or isinstance(grace, bool) or grace <= 0):
        raise Refused(f"{what}: grace={grace!r}: give the seconds (> 0), or None to keep it")
    return None if grace is None else float(grace)


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
