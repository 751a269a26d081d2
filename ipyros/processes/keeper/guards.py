"""A guard a session placed on this machine: its gate in front of the robot's topic, its stop process on
the robot's clock, its session's lease, and its rules over what the robot senses, read here, on the robot
(see :mod:`ipyros.processes.keeper`)."""

from __future__ import annotations

import copy
import time
from typing import Any, Optional

from ...core import msgtypes
from ...core.errors import DeclarationError, IpyrosError
from ...core.guard import Acting, Gate, RuleWatch, Verdict, check_rules, check_stop
from ...core.rules import RuleSet, as_rule
from ..basenode import log_dir
from ..sentinel import Sentinel, Shared
from .lease import Lease, Refused, beat_topics
from .ros import REPORT, Keeping, Reporter, child_env

__all__ = ["GUARD_START", "KeptGuard"]

#: How long a placed guard's stop process may take to start on the robot (s).
GUARD_START = 30.0
#: How long a guard placed with rules waits for the first message of each of their inputs before it acts (s): placed
#: again on a running robot, the guard it replaces keeps the robot meanwhile, and the robot is not stopped for a
#: sensor the new guard has only just subscribed to (one not heard by then: the stop message, as for one never heard).
INPUTS_FIRST_WAIT = 1.0


class KeptGuard:
    """A guard placed on this machine by a session: its gate in front of the robot's topic, its stop process, its
    lease."""

    def __init__(self, keeper: Keeping, owner: str, gid: str, spec: dict[str, Any]) -> None:
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
            self.rules = self._ruleset(spec, cls, where)
        except (DeclarationError, ValueError, TypeError) as error:
            raise Refused(str(error)) from None
        #: Each input of its rules: its last message and when it came (monotonic), heard on this machine.
        self.heard: dict[str, tuple[Any, float]] = {}
        self._arm_by = time.monotonic() + (INPUTS_FIRST_WAIT if self.rules is not None else 0.0)  # see armed
        self._replacing: Optional[KeptGuard] = None  # the guard it replaces, keeping the robot until it is armed
        self.repeat = float(spec.get("repeat", 10.0))
        self.watch = RuleWatch(self.repeat)  # what its rules do with no command coming (see _judge)
        self.lease = Lease(float(spec.get("lease", 0.5)), spec.get("grace_lease", 30.0), keeper.clock())
        self.shared = Shared.create()
        #: Why its stop process is gone, if it ended on its own: the guard then fails closed (see :meth:`tend`).
        self.lost: Optional[str] = None
        self._stopped_at = -float("inf")  # when the keeper last sent the stop message for a lost process
        self.gate = Gate(self.topic, cls, limits, rates, str(spec.get("on_limit", "clamp")), self.stop_message,
                         self.holding, self.shared.passed, lambda text: self._log(f"{where}: {text}"),
                         rules=self.rules, heard=lambda: self.heard)
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
                        for topic in beat_topics(f"{ns}/guards/{gid}")),
                      *(ros.subscribe(topic, str(type_name), self._hearing(topic), lossy=True)  # a sensor: best effort
                        for topic, type_name in dict(spec.get("inputs") or {}).items())]

    @staticmethod
    def _ruleset(spec: dict[str, Any], cls: type, where: str) -> Optional[RuleSet]:
        """Its rules over what the robot senses, from their data; the stop message checked against them."""
        rules, stale = list(spec.get("rules") or ()), dict(spec.get("stale") or {})
        if not rules and not stale:
            return None
        inputs = dict(spec.get("inputs") or {})
        ruleset = RuleSet([as_rule(r, where) for r in rules], cls, str(spec["topic"]),
                          {str(t): float(s) for t, s in stale.items()}, where)
        missing = [t for t in ruleset.topics if t not in inputs]
        if missing:
            raise DeclarationError(f"{where}: the types of {', '.join(missing)} were not sent: place it again")
        return ruleset

    def _hearing(self, topic: str) -> Any:
        def hear(msg: Any) -> None:
            self.heard[topic] = (msg, time.monotonic())
            said = self._judge(time.monotonic()) if self.armed else None  # an obstacle with no command coming: the stop message at once
            if said:
                self._log(said)

        return hear

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

    def check(self, msg: Any) -> Verdict:
        """The gate's verdict on ``msg`` (a session's command, a relay's message); one the gate fails on is the
        stop message in its place: when in doubt, stop (neither dropped, leaving the last command in force, nor sent
        unchecked). What a relay in the keeper passes its messages through (see ``Keeper.gate_relays``). Before it is
        :attr:`armed`, nothing (unless it holds the stop message: then that)."""
        if not self.armed and not self.holding():
            return Verdict(None)
        try:
            return self.gate.check(msg)
        except Exception as error:  # noqa: BLE001 - a bad message never ends the keeper
            self._log(f"guard {self.topic}: a message could not be checked ({error}): the stop message goes in its "
                      "place")
            return Verdict(self.stop_message(), Acting.ESTOPPED)

    def passes_raw(self, raw: Any, encoding: str) -> bool:
        """Whether a relay in the keeper forwards ``raw`` as it came (see ``Gate.raw_checker``); when in doubt, no:
        :meth:`check` reads it whole."""
        if not self.armed:
            return False
        try:
            return self.gate.passes_raw(raw, encoding)
        except Exception:  # noqa: BLE001 - read whole, where a failure is the stop message
            return False

    @property
    def armed(self) -> bool:
        """Whether it acts on the session's commands and judges its rules yet: once each input of its rules has been
        heard, or :data:`INPUTS_FIRST_WAIT` s after it was placed. Until then it sends nothing: placed again, the
        guard it replaces keeps the robot (see :meth:`replace`); placed first, nothing passes (its stop process stops
        the robot on silence)."""
        if self._arm_by and (time.monotonic() >= self._arm_by or self.rules is None
                             or all(topic in self.heard for topic in self.rules.topics)):
            self._arm_by = 0.0
        return not self._arm_by

    def command(self, msg: Any) -> None:
        """A message from the session: through the gate, onto the robot's topic (nothing before it is :attr:`armed`,
        but the stop message while it holds it)."""
        send = self.check(msg).send
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

    def replace(self, old: "KeptGuard") -> None:
        """Take over from ``old``, placed before it on the same topic: at once if armed, else once armed (the keeper's
        loop, :meth:`tend`): never a moment with no guard acting on the robot's topic."""
        if self.armed:
            old.close(hold=False)
        else:
            self._replacing = old

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
        armed, kept = self.armed, None
        if armed and self._replacing is not None:  # its sensors heard: it keeps the robot from now on
            old, self._replacing = self._replacing, None
            old.close(hold=False)
        elif self._replacing is not None:  # the guard it replaces keeps the robot: tended as before, its rules judged
            kept = self._replacing.tend(now)
        ruled = self._judge(time.monotonic()) if armed else None
        return "; ".join(line for line in (said, kept, ruled) if line) or None

    def _judge(self, now: float) -> Optional[str]:
        """Its rules judged with no new command, at each turn of the keeper's loop and as each input comes (an input
        gone stale or never heard, a stop rule, a last command they would now change): while they hold the stop
        message, the keeper sends it through its gate at the guard's rate, as a session's guard does (see
        :class:`~ipyros.core.guard.RuleWatch`); what changed, one line for its log and the session's report."""
        if self.rules is None:
            return None
        send, change = self.watch.look(self.gate.idle(), now)
        if send:
            self.command(self.stop_message())  # checked against its rules when it was placed: they pass it
        return f"guard {self.topic}: {RuleWatch.line(change)}" if change is not None else None

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
                "ruling": self.watch.ruling, "in_force": list(self.rules.acting) if self.rules is not None else [],
                "figures": [figures.passed, figures.clamped, figures.dropped, figures.replaced, figures.last_trip]}

    def report(self, now: float, every: float = REPORT) -> None:
        self._reporter.report(self.state(), now, every, steady=("figures",))

    def close(self, hold: bool) -> None:
        """End it: its stop process holds the stop message for its grace first (``hold``), or quits at once."""
        old, self._replacing = self._replacing, None
        if old is not None:
            old.close(hold=False)
        for sub in self._subs:
            sub.close()
        if self.sentinel is not None:
            self.sentinel.end(hold=hold, wait=False)
            self.sentinel = None
        self._out.close()
        self._reporter.close()
