"""The keeper itself: requests checked and done, leases watched, what it keeps reported; and how it
runs in its process (:func:`serve`)."""

from __future__ import annotations

import json
import os
import re
import secrets
import signal
import socket
import threading
import time
from typing import Any, Callable, Optional

from ...core.errors import IpyrosError
from .bases import KeptBase
from .guards import KeptGuard
from .lease import Refused, Token, Verifier, check_machine_name, namespace
from .relays import KeptRelays
from .ros import KeeperRos

__all__ = ["Keeper", "LOOK", "log_line", "serve", "unknown_packages"]

#: How often the keeper looks at its leases (s): the stop follows a lost lease within this.
LOOK = 0.01


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
            guard.replace(old)
        self.log(f"placed guard {guard.topic} for {guard.owner} (lease {guard.lease.length:g} s, grace "
                 f"{guard.lease.grace} s)")
        self._publish_info()
        guard.report(self.clock(), every=0.0)
        # what its rules read here: a session whose guard has rules refuses a keeper that does not say so (an older
        # one would place it without them)
        return {"id": gid, "reads": list(guard.rules.topics) if guard.rules is not None else []}

    def _owned(self, table: dict[str, Any], body: dict[str, Any], what: str) -> Any:
        """The thing ``body`` names in ``table`` (its guards, basenodes, relays), if the asking session placed it."""
        with self._lock:
            found = table.get(str(body.get("id")))
        if found is None or found.owner != body["from"]:
            raise Refused(f"no {what} {body.get('id')} of this session here")
        return found

    def _guard_of(self, body: dict[str, Any]) -> KeptGuard:
        return self._owned(self.guards, body, "guard")

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
        return self._owned(self.bases, body, "basenode")

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
            group.set_gate(topic, guard)

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
            what = group.add(rid, spec, guard)
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
        return self._owned(self.relays, body, "relays")

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
