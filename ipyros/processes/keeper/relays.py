"""The relays of a session's placed wrapping node, on this machine beside its basenode: in a relay host
(:mod:`ipyros.processes.relayhost`), or in the keeper through a guard's gate when one stands on the
relay's topic."""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any, Optional

from ...core import msgtypes, names
from ...core.errors import IpyrosError, first_line
from ...core.guard import Guarding
from ..basenode import log_dir
from ..relayhost import RelayHost, Relaying
from .lease import Lease, Refused, beat_topics, checked_grace
from .ros import REPORT, Keeping, Reporter, child_env

__all__ = ["KeptRelay", "KeptRelays"]

#: A message, service or action type as a relay's request may name it.
_TYPE = re.compile(r"^[A-Za-z][A-Za-z0-9_]*/((msg|srv|action)/)?[A-Za-z][A-Za-z0-9_]*$")


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
    """The relays of one session's placed wrapping node (one link for them all): run on this machine, beside
    its basenode, so that its topics cross the link once (to a handler in the session) or not at all. They run in a
    process of their own (:mod:`ipyros.processes.relayhost`: the leases' watch shares nothing with a camera's
    images), except a relay onto a topic a guard stands on here: that one runs in the keeper, through the guard's
    gate (see :meth:`Keeper.gate_relays`). They end when the session asks, or when it is silent past the grace
    (None: they are left running, as its basenode is)."""

    def __init__(self, keeper: Keeping, owner: str, lid: str, grace: Any) -> None:
        grace = checked_grace(grace, "relays")
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

    def add(self, rid: str, spec: dict[str, Any], gate: Optional[Guarding]) -> str:
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

    def _open(self, kept: KeptRelay, gate: Optional[Guarding]) -> None:
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
            except IpyrosError as error:  # it may relay on, onto a topic a guard now stands on or none should: when
                # in doubt, its process ends (all its relays with it; the relays' report says so to the session)
                self._keeper.log(f"{kept.what} of {self.owner}: {error}; their process is ended")
                self._host.close()

    def remove(self, rid: str) -> Optional[KeptRelay]:
        kept = self.relays.pop(rid, None)
        if kept is not None:
            self._close_one(kept)
        return kept

    def set_gate(self, topic: str, gate: Optional[Guarding]) -> None:
        """The guard on ``topic`` here changed: each relay onto it passes its check from now on (``gate``: the guard,
        :meth:`KeptGuard.check`; moved into the keeper, closed first: nothing passes unchecked meanwhile), or none
        (moved back to the relays' process)."""
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
