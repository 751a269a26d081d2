"""One guard of a running node, kept by the session: its gate in front of the output, the page it shares with its
sentinel process, the sentinel, the subscriptions its rules read, and what the prompt is told (see
:mod:`ipyros.core.guard`, :mod:`ipyros.core.rules` and :mod:`ipyros.processes.sentinel`). A guard placed on another
machine is :mod:`ipyros.node.placed`'s.
"""

from __future__ import annotations

import copy
import os
import time
from pathlib import Path
from typing import Any, Callable, Optional

from ..core import msgtypes
from ..core.guard import (EPISODE_QUIET, STATE_TOPIC, Acting, Gate, GuardState, RuleWatch, Verdict, check_stop,
                          verdict_text)
from ..core.model import GuardModel, TopicModel
from ..core.msgbuild import build_message
from ..core.names import tool_name
from ..core.qos import PROFILES, Qos
from ..core.rules import RuleSet, as_rule
from ..core.slots import HandlerSlot
from ..processes.basenode import log_dir
from ..processes.sentinel import ESTOPPED, PASSING, STATES, STOPPED, Sentinel, Shared

__all__ = ["LiveGuard", "limits_of"]

#: How long a guard's process may take to publish on its topic (s): a rospy or rclpy start, on a loaded machine.
SENTINEL_START = 30.0
#: How long a guard waits for the graph to show an input of its rules, whose type it subscribes with (s).
INPUT_TYPE_WAIT = 5.0
#: How long a guard waits for the first message of each input its rules newly read, before they judge (s): a
#: guard declared on a moving robot does not stop it for a sensor it has not heard yet only because it just
#: subscribed (one not heard by then: the stop message, said, as an input never heard is).
INPUT_FIRST_WAIT = 1.0
#: How its verdicts go out: the last ten kept for a subscriber that comes later (latched, on ROS 1 the last).
VERDICT_QOS = Qos(10, "reliable", "transient_local")

_count = iter(range(1, 1 << 30))


class LiveGuard:
    """One guard of a running node: what its output's endpoint passes every message through (:meth:`check`)."""

    def __init__(self, model: GuardModel, output: TopicModel, backend: Any, say: Callable[[str], None],
                 send: Callable[[str, Any], bool] = lambda topic, msg: False, host: str = "") -> None:
        self.topic, self.type = model.resolved, model.type
        self.cls = msgtypes.resolve_message(model.type)[1]
        self._backend, self._say, self._output, self._send, self._host = backend, say, output, send, host
        self.shared = Shared.create()
        self.model = model
        self._stop_message = self._make_stop(model)
        #: Its rules over what the robot senses (None: it has none), each input's last message and when it came
        #: (monotonic), and the subscriptions that hear them.
        self.rules = self._ruleset(model, self._stop_message)
        self.heard: dict[str, tuple[Any, float]] = {}
        self._inputs: dict[str, Any] = {}
        self.watch = RuleWatch(model.repeat)  # what its rules do with no command coming (see _look)
        self.gate = self._gate(model)
        self.sentinel: Optional[Sentinel] = None
        self._noticed, self._by_topic = self.shared.state, False
        self._commands_at = -1  # commands the gate had passed when the state last changed (none yet: -1)
        #: Why its process is gone, if it ended on its own: the guard then fails closed (see :meth:`tend`).
        self.lost: Optional[str] = None
        self._closing = False
        self._stopped_at = 0.0  # when the session last sent the stop message for a lost process (monotonic)
        self._unsent: Optional[str] = None  # why the session's last stop message could not be sent, if it could not
        self._verdicts: Any = None  # where it publishes what it does (<node>/guard_state), once started
        self._published: tuple[Optional[Acting], str, float] = (None, "", 0.0)  # its last verdict, and when

    # -- rules ------------------------------------------------------------------------------------
    def _make_stop(self, model: GuardModel) -> Any:
        stop = build_message(self.cls, model.stop) if model.stop is not None else self.cls()
        # checked when declared; again here, so that no way into the model sends one the gate would not pass
        check_stop(self.cls, stop, limits_of(model), f"guard {self.topic}", given=model.stop is not None)
        return stop

    def _ruleset(self, model: GuardModel, stop: Any) -> Optional[RuleSet]:
        if not model.rules and not model.stale:
            return None
        where = f"guard {self.topic}"
        rules = RuleSet([as_rule(r, where) for r in model.rules], self.cls, self.topic, model.stale, where)
        rules.check_stop(stop, where)  # checked when declared; again here, whatever way into the model it came
        return rules

    def _gate(self, model: GuardModel) -> Gate:
        return Gate(self.topic, self.cls, limits_of(model), dict(model.rate), model.on_limit, self.stop_message,
                    self.holding, self.shared.passed, self._say, rules=self._judged_here(), heard=lambda: self.heard,
                    report=self._publish_verdict)

    def _judged_here(self) -> Optional[RuleSet]:
        """The rules its gate judges in this process: all of them (a placed guard's are judged on its machine)."""
        return self.rules

    def _publish_verdict(self, acting: Acting, why: str) -> None:
        """A verdict published on ``<node>/guard_state`` (see :func:`~ipyros.core.guard.verdict_text`): what the
        prompt is told, as a value, for a recording to keep beside the commands."""
        verdicts, now = self._verdicts, time.time()
        last_acting, last_why, last_at = self._published
        if verdicts is None or acting is last_acting and last_why.startswith(why) and now - last_at < EPISODE_QUIET:
            return  # the gate said it as it replaced a message by the stop message; the watch says it again
        self._published = (acting, why, now)
        try:
            verdicts.write(msgtypes.resolve_message("std_msgs/String")[1](
                data=verdict_text(self.topic, acting, why, now)))
        except Exception:  # noqa: BLE001 - a verdict not published never changes what the guard does
            pass

    # -- what its rules read ----------------------------------------------------------------------
    def _listen(self, rules: Optional[RuleSet]) -> list[str]:
        """Subscribe to each input ``rules`` read that is not heard yet (best effort: a sensor's publisher of
        either reliability is heard); the topics newly subscribed. Its type is the live graph's, waited for a
        few seconds; one that does not show up, or is not installed here, is a one-line error (nothing kept)."""
        added: list[str] = []
        try:
            for topic in rules.topics if rules is not None else ():
                if topic not in self._inputs:
                    self._inputs[topic] = self._subscribe(topic)
                    added.append(topic)
        except BaseException:
            self._unlisten(added)
            raise
        return added

    def _hear_first(self, topics: list[str]) -> None:
        """Wait a moment (:data:`INPUT_FIRST_WAIT`) for the first message of each of ``topics``, just subscribed."""
        until = time.monotonic() + INPUT_FIRST_WAIT
        while any(topic not in self.heard for topic in topics) and time.monotonic() < until:
            time.sleep(0.01)

    def _input_type(self, topic: str) -> str:
        """The type the live graph shows for an input of its rules, waited for a few seconds; one line if none."""
        from ..core.errors import BaseNodeError

        deadline = time.monotonic() + INPUT_TYPE_WAIT
        while True:
            type_name = self._backend.graph_snapshot(timeout=1.0).topics.get(topic) or None
            if type_name is not None:
                return type_name
            if time.monotonic() > deadline:
                raise BaseNodeError(f"guard {self.topic}: its rules read {topic}, which nothing publishes, so its "
                                    "type is not known here: start what publishes it, then the node")
            time.sleep(0.1)

    def _subscribe(self, topic: str) -> Any:
        from ..core.errors import BaseNodeError

        type_name = self._input_type(topic)
        cls = msgtypes.message_class_or_none(type_name)
        if cls is None:
            raise BaseNodeError(f"guard {self.topic}: its rules read {topic}, a {type_name}, which is not installed "
                                f"here ({msgtypes.install_hint(type_name.split('/')[0])})")

        def hear(msg: Any) -> None:
            self.heard[topic] = (msg, time.monotonic())
            if self.sentinel is not None and not self._closing and self.lost is None:
                for line in self._look(time.monotonic()):  # an obstacle, no command coming: the stop message now
                    self._say(line)

        slot = HandlerSlot(f"guard {self.topic} input {topic}", hear,
                           lambda failure: self._say(f"guard {self.topic}: reading {topic}: {failure.error}"))
        return self._backend.subscription(self._host, topic, cls, slot, PROFILES["best_effort"],
                                          lambda text: self._say(f"guard {self.topic}: {text}"))

    def _unlisten(self, topics: Any) -> None:
        for topic in list(topics):
            endpoint = self._inputs.pop(topic, None)
            self.heard.pop(topic, None)
            if endpoint is not None:
                endpoint.close()

    def holding(self) -> bool:
        """Whether the stop message goes in place of every message: e-stopped, or its process lost."""
        return self.shared.estopped or self.lost is not None

    def stop_message(self) -> Any:
        """A fresh stop message (a gate may be handed it to send)."""
        return copy.deepcopy(self._stop_message)

    def update(self, model: GuardModel) -> None:
        """The guard declared again: its new rules from the next message on (its figures kept). The inputs its new
        rules read are subscribed first (a one-line error changes nothing); those no longer read are let go."""
        figures, commands = self.gate.figures, self.gate.commands
        stop = self._make_stop(model)
        rules = self._ruleset(model, stop)
        self._hear_first(self._listen(rules))  # the gate that judges them takes over once they are heard
        self._stop_message, self.rules = stop, rules
        self.gate = self._gate(model)
        self.gate.figures, self.gate.commands = figures, commands
        self.model, self.watch = model, RuleWatch(model.repeat)
        self._unlisten([t for t in self._inputs if rules is None or t not in rules.topics])
        self._tell({"settings": self._settings()})

    def _tell(self, message: dict[str, Any]) -> None:
        if self.sentinel is not None:
            try:
                self.sentinel.tell(message)
            except OSError:  # its process is gone: the watch finds it and says so (see tend())
                pass

    def check(self, msg: Any) -> Verdict:
        return self.gate.check(msg)

    def passes_raw(self, raw: Any, encoding: str) -> bool:
        return self.gate.passes_raw(raw, encoding)

    # -- its process ------------------------------------------------------------------------------
    def _settings(self) -> dict[str, Any]:
        model = self.model
        return {"timeout": model.timeout, "repeat": model.repeat, "grace": model.grace,
                "stop": self._backend.serialize(self._stop_message).hex()}

    def start(self) -> None:
        """Start its sentinel, and wait until it publishes on the topic; a one-line error if it cannot."""
        from ..core.errors import BaseNodeError

        name = f"{tool_name('guard')}_{next(_count)}"
        settings = {**self._settings(), "node": name, "topic": self.topic, "type": self.type,
                    "latch": bool(self._output.latch), "qos": self._output.qos, "estop_topic": self.model.estop_topic}
        env = dict(os.environ)
        package_root = str(Path(__file__).resolve().parents[2])  # ipyros importable as it is here
        env["PYTHONPATH"] = os.pathsep.join(p for p in (package_root, env.get("PYTHONPATH")) if p)
        log = log_dir() / f"{name}.log"
        self._hear_first(self._listen(self.rules))  # what its rules read, heard before anything passes
        try:
            self._open_verdicts()
            self.sentinel = Sentinel(self._backend.sentinel_command(), settings, self.shared, log, env)
        except BaseException:
            self._unlisten(list(self._inputs))
            self._close_verdicts()
            raise
        problem = self.sentinel.ready(SENTINEL_START)
        if problem is not None:
            self.sentinel = None
            self._unlisten(list(self._inputs))
            self._close_verdicts()
            raise BaseNodeError(f"the guard of {self.topic} could not start its process ({problem}); "
                                f"{'the stop message holds' if self.lost else 'nothing of the node runs'}: see {log}")

    def _open_verdicts(self) -> None:
        if self._verdicts is None:
            string = msgtypes.resolve_message("std_msgs/String")[1]
            self._verdicts = self._backend.publication(self._host, f"{self._host.rstrip('/')}/{STATE_TOPIC}", string,
                                                       VERDICT_QOS, lambda text: None)

    def _close_verdicts(self) -> None:
        verdicts, self._verdicts = self._verdicts, None
        if verdicts is not None:
            verdicts.close()

    def estop(self, on: bool) -> None:
        """Hold the stop message (``on``) or let commands pass again; the sentinel is woken to act at once. A
        release starts its process again if it was lost (a one-line error if it cannot: the stop message holds)."""
        self.shared.estop_session = on
        if not on and self.lost is not None:
            self._restart()
        self._tell({"wake": True})

    def _restart(self) -> None:
        if self.sentinel is not None:
            self.sentinel.end(hold=False)  # gone already: its pipe closed, its exit status read
            self.sentinel = None
        self.shared.ready, self.shared.state = False, PASSING
        self.start()
        self.lost, self._unsent = None, None
        self._noticed = PASSING

    def tend(self, now: float) -> list[str]:
        """Fail closed when its process ended on its own (killed, crashed): one line the first time; then, for as
        long as the session runs, every message is replaced by the stop message and the session itself sends it
        at the guard's rate (stop on silence no longer holds if the session freezes) until released. A stop
        message the session cannot send is said too, once until it can again: nothing else passes meanwhile,
        but the robot gets no stop message from the session either."""
        sentinel, said = self.sentinel, list[str]()
        if self.lost is None:
            if sentinel is None or self._closing or sentinel.running:
                return self._look(now) if sentinel is not None and not self._closing else said
            code = sentinel.returncode
            self.lost = f"killed by signal {-code}" if code is not None and code < 0 else f"exit code {code}"
            said.append(f"guard {self.topic}: its process ended ({self.lost}; its log: {sentinel.log_path}): the stop "
                        f"message goes in place of every message until released (%estop --release starts it again)")
        if now - self._stopped_at >= 1.0 / self.model.repeat:
            self._stopped_at = now
            problem = self._send_stop()
            if problem is not None and self._unsent is None:
                said.append(f"guard {self.topic}: the session cannot send the stop message ({problem}): nothing else "
                            f"passes, but no stop message reaches the robot from here; stop it with its own e-stop")
            elif problem is None and self._unsent is not None:
                said.append(f"guard {self.topic}: the session sends the stop message again")
            self._unsent = problem
        return said

    def _look(self, now: float) -> list[str]:
        """Its rules judged with no new command, at each look of the session's watch and as each input comes (an
        obstacle with no command coming: the stop message at once): while they hold the stop message (an input not
        heard or stale, a stop rule, a last command they would now change), the session sends it through the gate
        at the guard's rate; what changed is said once, and published."""
        send, change = self.watch.look(self.gate.idle(), now)
        if send:
            self._send_stop()  # through the gate: a stop message its rules let pass, or theirs in its place
        if change is None:
            return []
        self._publish_verdict(*change)
        return [f"guard {self.topic}: {RuleWatch.line(change)}"]

    def _send_stop(self) -> Optional[str]:
        """The stop message sent by the session on the guarded output; why not, if it could not be."""
        try:
            sent = self._send(self.topic, self.stop_message())
        except Exception as error:  # noqa: BLE001 - said by tend(), once; the next look sends it again
            return str(error).splitlines()[0] if str(error) else type(error).__name__
        return None if sent else "the node has no output open on it"

    def close(self, hold: bool) -> None:
        """End the guard: its sentinel holds the stop message for its grace first (``hold``: the node stops), or
        quits at once (the guard was removed; the output goes on unguarded)."""
        self._closing = True
        self._unlisten(list(self._inputs))
        self._close_verdicts()
        if self.sentinel is not None:
            self.sentinel.end(hold=hold, wait=not hold)
            self.sentinel = None

    # -- what it shows ------------------------------------------------------------------------------
    def state(self) -> GuardState:
        shared = self.shared
        state = STATES.get(shared.state, "passing") if self.sentinel is not None else "not running"
        if self.lost is not None:
            state = f"{STATES[ESTOPPED]} (its process ended: {self.lost})"
        elif shared.estopped:
            state = STATES[ESTOPPED] + (" (by its e-stop topic)" if shared.estop_topic else "")
        elif state == STATES[PASSING] and self.watch.ruling:  # its rules hold the stop message, no command coming
            state = f"stopping: {self.watch.ruling}"
        elif state == STATES[PASSING] and self.gate.replacing:  # messages go out, but each as the stop message
            state = f"stopping: {self.gate.replacing}"
        return GuardState(self.topic, state, self.gate.figures, shared.stops_sent, shared.reach,
                          self.rules.described() if self.rules is not None else ())

    def news(self) -> Optional[str]:
        """One line when the sentinel's state changed since the last look: a trip on silence, an e-stop by its
        topic, commands passing again after either (an e-stop from the session was said by who asked for it)."""
        state, by_topic = self.shared.state, self.shared.estop_topic
        if state == ESTOPPED and not by_topic and not self._by_topic:
            self._noticed = PASSING  # the session's own e-stop: its release is said by who asked for it too
            return None
        if state == self._noticed:
            return None
        if state == PASSING and self.gate.commands == self._commands_at:  # stop messages in place of each one
            return None  # went out, but no command has passed yet
        before, self._noticed, self._by_topic = self._noticed, state, by_topic
        self._commands_at = self.gate.commands
        if state == STOPPED:
            self._publish_verdict(Acting.SILENT, f"nothing passed for {self.model.timeout:g} s")
            return (f"guard {self.topic}: nothing passed for {self.model.timeout:g} s: its process sends the stop "
                    f"message ({self.model.repeat:g} Hz) until a command passes")
        if state == ESTOPPED:
            self._publish_verdict(Acting.ESTOPPED, f"by {self.model.estop_topic}")
            return f"guard {self.topic}: e-stopped by {self.model.estop_topic}: the stop message holds until released"
        if before in (STOPPED, ESTOPPED):
            self._publish_verdict(Acting.PASSED, "commands pass again")
            return f"guard {self.topic}: commands pass again"
        return None


def limits_of(model: GuardModel) -> dict[str, tuple[float, float]]:
    """A guard model's limits as the gate takes them (the model keeps lists: plain data)."""
    return {path: (bounds[0], bounds[1]) for path, bounds in model.limits.items()}
