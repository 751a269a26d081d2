"""A guard placed on another machine (``nd.guard(topic, ..., machine="robot1")``): the session's side of it.

The guard's gate and its stop process run on the robot, in the keeper there (see
:mod:`ipyros.processes.keeper`): the node's messages on the guarded output go to the keeper, which
checks them and publishes them on the robot; the stop on silence, the e-stop, and the stop when the
session is not heard for the guard's lease are the robot's, on its own clock. Here the session keeps
a gate of the same rules (it says at once what it clamps), signs a heartbeat for the lease, asks
the keeper (signed requests) to place, e-stop, release and remove the guard, and shows what the
keeper reports of it.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any, Callable

from ..core.guard import GuardState, Verdict
from ..core.model import GuardModel, TopicModel
from ..core.qos import from_model
from ..processes.keeper import MachineError
from ..processes.sentinel import ESTOPPED, PASSING, STATES
from .keeperlink import FIND, KeeperLink
from .liveguard import LiveGuard

__all__ = ["PlacedGuard"]


class PlacedGuard(LiveGuard):
    """One guard of a running node, kept by the keeper of ``model.machine``."""

    def __init__(self, model: GuardModel, output: TopicModel, backend: Any, say: Callable[[str], None],
                 send: Callable[[str, Any], bool], host: str) -> None:
        assert model.machine is not None
        self.machine = model.machine
        # the token is read before anything opens
        self._link = KeeperLink(backend, host, self.machine, "guards", f"guard {model.resolved}", say)
        super().__init__(model, output, backend, say, send, host)
        self.id = self._link.id
        self._silent_said = False

    def _lossy(self) -> bool:
        """Whether the output is best effort: then so is the link carrying its commands to the keeper (ROS 2: a lost
        command is not repaired, and holds none back behind it)."""
        return from_model(self._output.qos).reliability == "best_effort"

    def _report(self, report: dict[str, Any]) -> None:
        shared = self.shared
        shared.state, shared.stops_sent, shared.reach = report["state"], report["stops"], report["reach"]
        shared.estop_topic = report["estop_topic"]
        # what its rules do on the robot, published here as the session's own are
        _, change = self.watch.look(str(report.get("ruling", "")), time.monotonic())
        if change is not None:
            self._publish_verdict(*change)

    def _spec(self) -> dict[str, Any]:
        model = self.model
        # its rules' inputs with the types the live graph shows (the robot's sensors: the keeper subscribes there)
        inputs = {topic: self._input_type(topic) for topic in self.rules.topics} if self.rules is not None else {}
        return {"topic": self.topic, "type": self.type, "limits": model.limits, "rate": model.rate,
                "on_limit": model.on_limit, "timeout": model.timeout, "repeat": model.repeat, "grace": model.grace,
                "estop_topic": model.estop_topic, "latch": bool(self._output.latch),
                "stop": self._backend.serialize(self._stop_message).hex(), "lease": model.lease,
                "grace_lease": model.machine_grace, "lossy": self._lossy(),
                "rules": list(model.rules), "stale": dict(model.stale), "inputs": inputs}

    def _judged_here(self) -> None:
        """None: its rules are judged on the robot by the keeper, which reads the sensors there; the session's gate
        checks the limits (and says at once what it clamps)."""
        return None

    def _listen(self, rules: Any) -> list[str]:
        return []  # the keeper subscribes to the rules' inputs, on the robot

    # -- what a LiveGuard does, here done by the keeper ------------------------------------------------
    def start(self) -> None:
        link = self._link
        link.open(self._report)
        self._in = link.publication(f"{link.topics}/in", self.cls, lossy=self._lossy())
        try:
            self._open_verdicts()
            link.beat(min(0.1, self.model.lease / 5))
            self._place()
            # The keeper lets no command pass until it hears this session's heartbeat (a new subscription takes a
            # moment to be found): create() returns once it does, or after FIND s, and then tend() says why not.
            until = time.monotonic() + FIND
            while not link.report.get("heard") and time.monotonic() < until:
                time.sleep(0.02)
        except BaseException:
            self._close_verdicts()
            link.close()
            raise
        link.heard_at = time.monotonic()

    def check(self, msg: Any) -> Verdict:
        """Checked here too (what it clamps is said at once), then sent to the keeper: nothing leaves here."""
        verdict = self.gate.check(msg)
        if verdict.send is not None:
            self._in.write(verdict.send)
        return Verdict(None, verdict.acting, verdict.path)

    def passes_raw(self, raw: Any, encoding: str) -> bool:
        """False: every message goes to the keeper as an object (:meth:`check`), never on here as bytes."""
        return False

    def update(self, model: GuardModel) -> None:
        super().update(model)
        self._place(again=True)

    def _place(self, again: bool = False) -> None:
        """Ask the keeper to place it (``again``: its new rules, on a running node). A keeper that does not say it
        reads its rules' inputs (an older ipyros there, which keeps the limits and drops the rules) is refused in
        one line, its rules never silently not enforced: the guard there is removed, holding the stop message for
        its grace (placed again: e-stopped there, until released)."""
        answer = self._link.ask("place", again=True, guard=self._spec())
        wanted = sorted(self.rules.topics) if self.rules is not None else []
        if not wanted or sorted(answer.get("reads") or ()) == wanted:
            return
        try:
            if again:
                self.estop(True)
            else:
                self._link.ask("remove", timeout=3.0, hold=True)
        except MachineError:
            pass  # unreached, its lease runs out there: the robot holds the stop message all the same
        raise MachineError(f"guard {self.topic}: the keeper of machine {self.machine} does not judge a guard's rules "
                           f"(an older ipyros runs there){': it is e-stopped' if again else ''}; update ipyros there "
                           "and start its keeper again, or declare the guard without rules")

    def _tell(self, message: dict[str, Any]) -> None:
        pass  # no process of the session's: the keeper is asked (update, estop)

    def estop(self, on: bool) -> None:
        self.shared.estop_session = on
        self._link.ask("estop", timeout=5.0, on=on)

    def tend(self, now: float) -> list[str]:
        """Say when the keeper's reports stop (the link lost, the keeper gone) and when they come again, and when
        the guard's stop process ended on the machine (the keeper then holds the stop message until released)."""
        lost = self._link.report.get("lost")
        if lost != self.lost:
            self.lost = lost
            if lost:
                return [f"guard {self.topic}: its stop process ended on machine {self.machine} ({lost}): the robot "
                        f"gets the stop message in place of every command until released (%estop --release starts "
                        f"it again)"]
        silent = now - self._link.heard_at
        if not self._silent_said and silent > max(self.model.lease, 0.5):
            self._silent_said = True
            return [f"guard {self.topic}: no word from machine {self.machine} for {silent:.1f} s: if the link is "
                    f"lost, the robot holds the stop message until it hears this session again"]
        if self._silent_said and silent < 0.5:
            self._silent_said = False
            return [f"guard {self.topic}: machine {self.machine} heard again: its guard passes commands again"]
        return []

    def state(self) -> GuardState:
        report = self._link.report
        where = f" (on {self.machine})"
        if not report:
            return GuardState(self.topic, "placing" + where, self.gate.figures)
        if report.get("held"):
            state = "stopped: the session not heard"
        elif report.get("estop_session") or report.get("estop_topic"):
            state = STATES[ESTOPPED] + (" (by its e-stop topic)" if report.get("estop_topic") else "")
        else:
            state = STATES.get(report.get("state", PASSING), "passing")
        if report.get("lost"):
            state = f"{STATES[ESTOPPED]} (its stop process ended: {report['lost']})"
        elif not report.get("alive"):
            state = "its stop process ended on the machine"
        elif report.get("ruling") and state == STATES[PASSING]:  # its rules hold the stop message there
            state = f"stopping: {report['ruling']}"
        # What the session's own gate did (the same rules: the keeper's gate then passes what it sends), and the
        # stop messages the keeper put in place of commands (e-stopped, or the session not heard).
        figures = dataclasses.replace(self.gate.figures)
        figures.replaced += report["figures"][3]
        return GuardState(self.topic, state + where, figures, report.get("stops", 0), report.get("reach", 0),
                          self.rules.described(report.get("in_force", ())) if self.rules is not None else ())

    def close(self, hold: bool) -> None:
        self._closing = True
        try:
            self._link.ask("remove", timeout=3.0, hold=hold)
        except MachineError as error:
            self._say(f"guard {self.topic}: {error}; its lease runs out there: the robot holds the stop message, "
                      "then ends the guard after its grace")
        finally:
            self._close_verdicts()
            self._link.close()

