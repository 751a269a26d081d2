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
import json
import secrets
import threading
import time
from typing import Any, Callable, Optional

from ..core import msgtypes
from ..core.guard import GuardState, Verdict
from ..core.model import GuardModel, TopicModel
from ..core.qos import PROFILES
from ..core.slots import HandlerSlot
from ..processes.keeper import MachineError, Token, beat_text, namespace, token_path
from ..processes.sentinel import ESTOPPED, PASSING, STATES
from .liveguard import LiveGuard

__all__ = ["PlacedGuard"]

#: How long the keeper may take to answer a request (s): placing starts a process on the robot.
ANSWER = 40.0
#: How long the session waits for a keeper's first word (s) before it says none is there.
FIND = 10.0

_STRING = "std_msgs/String"


class PlacedGuard(LiveGuard):
    """One guard of a running node, kept by the keeper of ``model.machine``."""

    def __init__(self, model: GuardModel, output: TopicModel, backend: Any, say: Callable[[str], None],
                 send: Callable[[str, Any], bool], host: str) -> None:
        assert model.machine is not None
        self.machine = model.machine
        self._token = Token.read(token_path(self.machine), self.machine)  # before anything opens
        super().__init__(model, output, backend, say, send)
        self._host = host
        self.id = secrets.token_hex(6)
        self._sender = f"s{secrets.token_hex(6)}"
        self._n = time.time_ns()  # grows across the session's requests and beats, never repeats
        self._lock = threading.Lock()
        self._epoch: Optional[str] = None
        self._answers: dict[int, dict[str, Any]] = {}
        self._answered = threading.Condition(self._lock)
        self._report: dict[str, Any] = {}
        self._heard_at = 0.0  # when the keeper last reported on this guard (monotonic; 0: never)
        self._silent_said = False
        self._ending = threading.Event()
        self._endpoints: list[Any] = []
        self._beating: Optional[threading.Thread] = None

    # -- its endpoints ------------------------------------------------------------------------------
    def _open(self) -> None:
        backend, host, ns = self._backend, self._host, namespace(self.machine)
        string = msgtypes.resolve_message(_STRING)[1]
        quiet = lambda text: None  # noqa: E731 - a complaint of these endpoints is said by tend()

        def slot(label: str, handler: Callable[[Any], None]) -> HandlerSlot:
            return HandlerSlot(f"guard {self.topic} on {self.machine} {label}", handler,
                               lambda failure: self._say(f"guard {self.topic}: {failure.error}"))

        self._endpoints = [
            backend.subscription(host, f"{ns}/info", string, slot("info", self._info), PROFILES["latched"], quiet),
            backend.subscription(host, f"{ns}/reply", string, slot("reply", self._reply), PROFILES["default"], quiet),
            backend.subscription(host, f"{ns}/guards/{self.id}/state", string, slot("state", self._state),
                                 PROFILES["latched"], quiet)]
        self._request = backend.publication(host, f"{ns}/request", string, PROFILES["default"], quiet)
        self._beat = backend.publication(host, f"{ns}/guards/{self.id}/beat", string, PROFILES["default"], quiet)
        self._in = backend.publication(host, f"{ns}/guards/{self.id}/in", self.cls, PROFILES["default"], quiet)
        self._endpoints += [self._request, self._beat, self._in]
        self._string = string

    def _info(self, msg: Any) -> None:
        try:
            epoch = json.loads(msg.data)["epoch"]
        except (ValueError, KeyError, TypeError):
            return
        with self._lock:
            self._epoch = epoch
            self._answered.notify_all()

    def _reply(self, msg: Any) -> None:
        try:
            answer = json.loads(msg.data)
        except ValueError:
            return
        if answer.get("to") != self._sender or not isinstance(answer.get("n"), int):
            return
        with self._lock:
            self._answers[answer["n"]] = answer
            self._answered.notify_all()

    def _state(self, msg: Any) -> None:
        try:
            report = json.loads(msg.data)
        except ValueError:
            return
        self._report, self._heard_at = report, time.monotonic()
        shared = self.shared
        shared.state, shared.stops_sent, shared.reach = report["state"], report["stops"], report["reach"]
        shared.estop_topic = report["estop_topic"]

    def _next(self) -> int:
        with self._lock:
            self._n += 1
            return self._n

    def _ask(self, op: str, timeout: float = ANSWER, **fields: Any) -> dict[str, Any]:
        """A signed request to the keeper, asked again each second until it answers (a request may go out before
        the keeper's subscriber has found this session's publisher); its answer, or a one-line error."""
        deadline = time.monotonic() + timeout
        found_by = min(deadline, time.monotonic() + FIND)
        with self._lock:
            while self._epoch is None and time.monotonic() < found_by:
                self._answered.wait(0.05)
            epoch = self._epoch
        if epoch is None:
            raise MachineError(f"no keeper of machine {self.machine} answers on this ROS graph within {FIND:g} s: "
                               f"start it on the robot (python -m ipyros.machine --name {self.machine}) with the same "
                               "ROS_MASTER_URI")
        while time.monotonic() < deadline:
            n = self._next()
            body = {"epoch": epoch, "from": self._sender, "n": n, "op": op, "id": self.id, **fields}
            self._request.write(self._string(data=self._token.signed(body)))
            with self._lock:
                until = min(deadline, time.monotonic() + 1.0)
                while n not in self._answers and time.monotonic() < until:
                    self._answered.wait(0.02)
                answer = self._answers.pop(n, None)
            if answer is not None:
                if not answer.get("ok"):
                    raise MachineError(f"machine {self.machine} refused: {answer.get('error')}")
                return answer
            if op != "place":  # placing is asked again; the rest must not be done twice
                break
        raise MachineError(f"machine {self.machine} did not answer {op!r} within {timeout:g} s: the link to it may be "
                           "lost")

    def _beats(self) -> None:
        period = min(0.1, self.model.lease / 5)
        while not self._ending.wait(period):
            epoch = self._epoch
            if epoch is None:
                continue
            try:
                self._beat.write(self._string(data=beat_text(self._token, epoch, self._sender, self._next())))
            except Exception:  # noqa: BLE001 - the link or the node ending: tend() says what the keeper reports
                continue

    def _spec(self) -> dict[str, Any]:
        model = self.model
        return {"topic": self.topic, "type": self.type, "limits": model.limits, "rate": model.rate,
                "on_limit": model.on_limit, "timeout": model.timeout, "repeat": model.repeat, "grace": model.grace,
                "estop_topic": model.estop_topic, "latch": bool(self._output.latch),
                "stop": self._backend.serialize(self._stop_message).hex(), "lease": model.lease,
                "grace_lease": model.machine_grace}

    # -- what a LiveGuard does, here done by the keeper ------------------------------------------------
    def start(self) -> None:
        self._open()
        try:
            self._beating = threading.Thread(target=self._beats, name="ipyros-lease", daemon=True)
            self._beating.start()
            self._ask("place", guard=self._spec())
        except BaseException:
            self._shut()
            raise
        self._heard_at = time.monotonic()

    def check(self, msg: Any) -> Verdict:
        """Checked here too (what it clamps is said at once), then sent to the keeper: nothing leaves here."""
        verdict = self.gate.check(msg)
        if verdict.send is not None:
            self._in.write(verdict.send)
        return Verdict(None, verdict.acting, verdict.path)

    def update(self, model: GuardModel) -> None:
        super().update(model)
        self._ask("place", guard=self._spec())

    def _tell(self, message: dict[str, Any]) -> None:
        pass  # no process of the session's: the keeper is asked (update, estop)

    def estop(self, on: bool) -> None:
        self.shared.estop_session = on
        self._ask("estop", timeout=5.0, on=on)

    def tend(self, now: float) -> list[str]:
        """Say when the keeper's reports stop (the link lost, the keeper gone) and when they come again, and when
        the guard's stop process ended on the machine (the keeper then holds the stop message until released)."""
        lost = self._report.get("lost")
        if lost != self.lost:
            self.lost = lost
            if lost:
                return [f"guard {self.topic}: its stop process ended on machine {self.machine} ({lost}): the robot "
                        f"gets the stop message in place of every command until released (%estop --release starts "
                        f"it again)"]
        silent = now - self._heard_at
        if not self._silent_said and silent > max(self.model.lease, 0.5):
            self._silent_said = True
            return [f"guard {self.topic}: no word from machine {self.machine} for {silent:.1f} s: if the link is "
                    f"lost, the robot holds the stop message until it hears this session again"]
        if self._silent_said and silent < 0.5:
            self._silent_said = False
            return [f"guard {self.topic}: machine {self.machine} heard again: its guard passes commands again"]
        return []

    def state(self) -> GuardState:
        report = self._report
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
        # What the session's own gate did (the same rules: the keeper's gate then passes what it sends), and the
        # stop messages the keeper put in place of commands (e-stopped, or the session not heard).
        figures = dataclasses.replace(self.gate.figures)
        figures.replaced += report["figures"][3]
        return GuardState(self.topic, state + where, figures, report.get("stops", 0), report.get("reach", 0))

    def close(self, hold: bool) -> None:
        self._closing = True
        try:
            self._ask("remove", timeout=3.0, hold=hold)
        except MachineError as error:
            self._say(f"guard {self.topic}: {error}; its lease runs out there: the robot holds the stop message, "
                      "then ends the guard after its grace")
        finally:
            self._shut()

    def _shut(self) -> None:
        self._ending.set()
        for endpoint in self._endpoints:
            try:
                endpoint.close()
            except Exception:  # noqa: BLE001 - ending anyway
                pass
        self._endpoints = []
