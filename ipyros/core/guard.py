"""A safety guard's rules, and the gate every message of a guarded output passes (pure: no ROS, no clock of ROS).

``nd.guard("/cmd_vel", limits={"linear.x": (-0.5, 0.5)}, timeout=0.5)`` declares a guard on an
output of a node; every message that leaves the node on that topic, whatever sent it, goes
through its :class:`Gate` first:

* a value outside its limits is clamped to them (``on_limit="clamp"``, the default) or the message
  is dropped (``"drop"``); a field given a rate limit changes by at most that much per second
  (an acceleration limit: ``rate={"linear.x": 1.0}``), from the last value that passed;
* a message holding NaN or an infinity anywhere in its numbers never passes: the stop message
  goes out in its place (when in doubt, stop);
* while the guard is e-stopped (``%estop``, ``nd.estop()``, or its e-stop topic), every message
  is replaced by the stop message.

What it does not promise: this is not certified functional safety. It checks what ipyros sends,
in the session and in a small process of the session's that sends the stop message on silence
(:mod:`ipyros.processes.sentinel`); a robot's hardware e-stop and its own controllers stay the last
line. A message is checked field by field as ROS delivers it; what another publisher sends on the
same topic is not seen.

Fields are named by path: ``linear.x``, ``axes[2]``, ``poses[*].position.x`` (every element; ``[:]``
too), on messages of either ROS (:mod:`ipyros.core.msgbuild` reads their fields).
"""

from __future__ import annotations

import copy
import enum
import json
import math
import re
import threading
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Optional, Protocol

from . import wire
from .errors import DeclarationError, cut
from .msgbuild import copy_message, field_types, nested_class
from .rules import CHANGED_LAST, RuleSet

__all__ = ["DEFAULT_GRACE", "DEFAULT_LEASE", "DEFAULT_MACHINE_GRACE", "DEFAULT_REPEAT", "EPISODE_QUIET", "ESTOP_TYPE",
           "RULES_PASS", "STATE_TOPIC", "Acting", "Gate", "GuardFigures", "Guarding", "Path", "RuleWatch", "Verdict",
           "check_rules", "check_stop", "finite_checker", "parse_path", "verdict_text"]

#: The type of a guard's e-stop topic: ``True`` holds the stop message.
ESTOP_TYPE = "std_msgs/Bool"
#: How long the stop message is held after the session ends for good (s), unless the guard says.
DEFAULT_GRACE = 3.0
#: The most a guard holds it: its process must end (no process of the session outlives it for long).
MOST_GRACE = 10.0
#: How often the stop message is sent again while it holds (Hz), unless the guard says.
DEFAULT_REPEAT = 10.0
#: A guard placed on a machine: how long its keeper waits to hear the session before it holds the stop message (s),
#: and how long before it ends the guard (s).
DEFAULT_LEASE = 0.5
DEFAULT_MACHINE_GRACE = 30.0
#: An episode of a guard's acting ends when this long (s) has passed with nothing for it to do: each kind
#: of acting (clamped, dropped, not finite, e-stopped) is said once an episode, however the kinds alternate.
EPISODE_QUIET = 1.0
#: Where a node's guards publish what they do (``std_msgs/String``, one JSON object a message: see
#: :func:`verdict_text`), under the node's name, as ``~guard_state``: recorded with the commands, replayed beside them.
STATE_TOPIC = "guard_state"
#: What a guard says when its rules, which held the stop message with no command coming, let commands pass again.
RULES_PASS = "its rules let commands pass again"
_NUMBERS = {"float32", "float64", "int8", "int16", "int32", "int64", "uint8", "uint16", "uint32", "uint64",
            "byte", "char"}
_FLOATS = {"float32", "float64"}
_STEP = re.compile(r"(?P<name>[A-Za-z_]\w*)(?:\[(?P<index>-?\d+|\*|:)\])?$")


# -- paths ------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Path:
    """A numeric field of a message type, by path: its steps (name, index: None, an int, or "*" for every one)."""

    text: str
    steps: tuple[tuple[str, Any], ...]
    kind: str  # the field's type (float64, int32, ...)

    def values(self, msg: Any) -> list[tuple[Any, Any, Any]]:
        """``(owner, key, value)`` of each value the path names in ``msg``; ``key`` is an attribute name or, for an
        array element, ``(attribute, index)``."""
        found = [msg]
        last = len(self.steps) - 1
        out: list[tuple[Any, Any, Any]] = []
        for number, (name, index) in enumerate(self.steps):
            nxt = []
            for owner in found:
                value = getattr(owner, name)
                if index is None:
                    if number == last:
                        out.append((owner, name, value))
                    else:
                        nxt.append(value)
                    continue
                items = range(len(value)) if index == "*" else [index] if -len(value) <= index < len(value) else []
                for i in items:
                    if number == last:
                        out.append((owner, (name, i), value[i]))
                    else:
                        nxt.append(value[i])
            found = nxt
        return out

    @staticmethod
    def set(owner: Any, key: Any, value: Any) -> None:
        if isinstance(key, tuple):
            name, index = key
            array = getattr(owner, name)
            if isinstance(array, tuple):  # genpy gives fixed arrays as tuples
                items = list(array)
                items[index] = value
                setattr(owner, name, type(array)(items))
            else:
                array[index] = value
        else:
            setattr(owner, key, value)


def parse_path(cls: type, text: Any, where: str) -> Path:
    """``text`` as a :class:`Path` into messages of ``cls``; a one-line error naming the fields there are."""
    if not isinstance(text, str) or not text.strip():
        raise DeclarationError(f"{where}: a field is named by its path, like 'linear.x' or 'axes[2]', "
                               f"not {cut(text)}")
    steps: list[tuple[str, Any]] = []
    current: Optional[type] = cls
    kind = ""
    parts = text.strip().split(".")
    for number, part in enumerate(parts):
        matched = _STEP.match(part)
        if matched is None or current is None:
            raise DeclarationError(f"{where}: {text!r} is not a field path; write it like 'linear.x', "
                                   "'axes[2]' or 'poses[*].position.x'")
        name, index = matched["name"], matched["index"]
        names, types = field_types(current)
        if name not in names:
            raise DeclarationError(f"{where}: {text!r}: no field {name!r} (there: {', '.join(names) or 'none'})")
        kind = types[names.index(name)]
        array = re.match(r"^(?P<base>[^\[\]]+)\[\d*\]$", kind)
        if array is not None and index is None and number < len(parts) - 1:
            raise DeclarationError(f"{where}: {text!r}: {name} is an array; name its elements, "
                                   f"'{name}[*]' or '{name}[0]'")
        if array is None and index is not None:
            raise DeclarationError(f"{where}: {text!r}: {name} is not an array")
        if array is not None and index is not None:
            kind = array["base"]
            index = "*" if index in ("*", ":") else int(index)
        elif array is not None:
            raise DeclarationError(f"{where}: {text!r} is an array of {array['base']}: limit its elements, "
                                   f"'{name}[*]'")
        steps.append((name, index))
        current = nested_class(kind) if number < len(parts) - 1 else None
        if number < len(parts) - 1 and current is None:
            raise DeclarationError(f"{where}: {text!r}: {name} is a {kind}, which has no fields")
    if kind not in _NUMBERS:
        raise DeclarationError(f"{where}: {text!r} is a {kind}, not a number: a limit bounds numbers")
    return Path(text.strip(), tuple(steps), kind)


# -- the rules, checked --------------------------------------------------------------------------

def _number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def check_rules(cls: type, limits: Any, rate: Any, on_limit: Any, timeout: Any, grace: Any, repeat: Any,
                where: str) -> tuple[dict[str, tuple[float, float]], dict[str, float]]:
    """The guard's settings checked against messages of ``cls``; each refusal one line saying what to give.
    Returns the limits and rates, their numbers as floats."""
    checked_limits: dict[str, tuple[float, float]] = {}
    if limits is not None:
        if not isinstance(limits, dict):
            raise DeclarationError(f"{where}: limits={cut(limits)}: give a dict of field paths and (low, high), "
                                   "e.g. limits={'linear.x': (-0.5, 0.5)}")
        for path, bounds in limits.items():
            parse_path(cls, path, where)
            if not (isinstance(bounds, (tuple, list)) and len(bounds) == 2 and all(map(_number, bounds))
                    and bounds[0] <= bounds[1]):
                raise DeclarationError(f"{where}: limits[{path!r}] = {cut(bounds)}: give (low, high), two finite "
                                       "numbers with low <= high, e.g. (-0.5, 0.5)")
            checked_limits[path.strip()] = (float(bounds[0]), float(bounds[1]))
    checked_rates: dict[str, float] = {}
    if rate is not None:
        if not isinstance(rate, dict):
            raise DeclarationError(f"{where}: rate={cut(rate)}: give a dict of field paths and the most they may "
                                   "change in a second, e.g. rate={'linear.x': 1.0}")
        for path, most in rate.items():
            parse_path(cls, path, where)
            if not _number(most) or most <= 0:
                raise DeclarationError(f"{where}: rate[{path!r}] = {cut(most)}: give the most the field may change "
                                       "in a second, a number above 0")
            checked_rates[path.strip()] = float(most)
    if on_limit not in ("clamp", "drop"):
        raise DeclarationError(f"{where}: on_limit={cut(on_limit)}: give 'clamp' (a value outside its limits is set "
                               "to the nearest) or 'drop' (the message is not sent)")
    if timeout is not None and (not _number(timeout) or not 0.01 <= timeout <= 3600):
        raise DeclarationError(f"{where}: timeout={cut(timeout)}: give the seconds of silence after which the stop "
                               "message is sent, from 0.01 up (diff_drive_controller's default: 0.5)")
    if not _number(grace) or not 0 <= grace <= MOST_GRACE:
        raise DeclarationError(f"{where}: grace={cut(grace)}: give the seconds the stop message is held after the "
                               f"session ends, from 0 to {MOST_GRACE:g}")
    if not _number(repeat) or not 0.5 <= repeat <= 1000:
        raise DeclarationError(f"{where}: repeat={cut(repeat)}: give how often (Hz) the stop message is sent again "
                               "while it holds, from 0.5 to 1000")
    return checked_limits, checked_rates


def check_stop(cls: type, stop: Any, limits: dict[str, tuple[float, float]], where: str, given: bool) -> None:
    """Refuse a stop message the guard's own gate would not pass (a NaN, or a value outside its limits): the
    e-stop and the stop on silence send it unchecked, so it must be within the rules it stands for. ``given``:
    the user gave it (``stop=``), else it is the type's zero message."""
    bad = finite_checker(cls)(stop)
    if bad is not None:
        raise DeclarationError(f"{where}: the stop message's {bad} is not a finite number; give a stop message "
                               "of finite values within the limits")
    for text, (low, high) in limits.items():
        path = parse_path(cls, text, where)
        for _, _, value in path.values(stop):
            if not low <= value <= high:
                whose = "the stop message" if given else "the stop message (the type's zero message)"
                raise DeclarationError(f"{where}: {whose} has {path.text} = {value:g}, outside the guard's own limits "
                                       f"{low:g}..{high:g}: the e-stop would send it; give stop= within the limits")


# -- NaN and infinities, anywhere ----------------------------------------------------------------

_FINITE_CHECKERS: dict[type, Callable[[Any], Optional[str]]] = {}


def finite_checker(cls: type) -> Callable[[Any], Optional[str]]:
    """``check(msg)``: the path of the first NaN or infinity in a message of ``cls``, or None. Made once per
    class as straight-line code (one ``isfinite`` per float field; arrays of floats looped over)."""
    found = _FINITE_CHECKERS.get(cls)
    if found is not None:
        return found
    names, types = field_types(cls)
    scope: dict[str, Any] = {"isfinite": math.isfinite}
    lines = ["def check(m):"]
    for i, (name, kind) in enumerate(zip(names, types)):
        if not name.isidentifier():
            continue
        array = re.match(r"^(?P<base>[^\[\]]+)\[\d*\]$", kind)
        base = array["base"] if array else kind
        if base in _FLOATS:
            if array:
                lines += [f"    for i, v in enumerate(m.{name}):",
                          f"        if not isfinite(v): return '{name}[' + str(i) + ']'"]
            else:
                lines.append(f"    if not isfinite(m.{name}): return {name!r}")
        elif base not in _NUMBERS and base not in ("bool", "string", "time", "duration"):
            nested = nested_class(base)
            if nested is None:
                continue
            scope[f"c{i}"] = finite_checker(nested)
            if array:
                lines += [f"    for i, v in enumerate(m.{name}):",
                          f"        bad = c{i}(v)",
                          f"        if bad: return '{name}[' + str(i) + '].' + bad"]
            else:
                lines += [f"    bad = c{i}(m.{name})", f"    if bad: return '{name}.' + bad"]
    lines.append("    return None")
    exec("\n".join(lines), scope)  # noqa: S102 - our own code, from the class's field names
    found = _FINITE_CHECKERS[cls] = scope["check"]
    return found


# -- the gate --------------------------------------------------------------------------------------

class Acting(enum.Enum):
    """What a gate did with one message: a value, for whoever reads verdicts (the prompt's lines, %status, a
    recording of them), not English to be parsed."""

    PASSED = "passed"  # as it came
    CLAMPED = "clamped"  # a value set within its limits, or its rate
    DROPPED = "dropped"  # outside its limits, with on_limit="drop": nothing sent
    NOT_FINITE = "not finite"  # a NaN or an infinity: the stop message in its place
    ESTOPPED = "e-stopped"  # the stop message in its place, whatever came
    RULE_STOPPED = "stopped by a rule"  # a rule over what the robot senses: the stop message in its place
    SILENT = "stopped on silence"  # nothing passed for its timeout: its process sends the stop message


def verdict_text(output: str, acting: Acting, why: str, stamp: float) -> str:
    """One verdict of a guard as a line of JSON (``~guard_state``'s ``data``): its output, what it did (an
    :class:`Acting` value: ``"passed"`` once commands pass again), why in words (the rule and its input, the field),
    and when (seconds since the epoch). ``json.loads(msg.data)`` reads it back."""
    return json.dumps({"output": output, "acting": acting.value, "why": why, "stamp": round(stamp, 6)},
                      separators=(", ", ": "))


@dataclass(frozen=True)
class Verdict:
    """What the gate made of one message: ``send`` it (clamped, or the stop message in its place), or nothing;
    ``acting`` says which, ``path`` the field that made it so (a non-finite one's)."""

    send: Any  # the message to send, or None: dropped
    acting: Acting = Acting.PASSED
    path: str = ""

    @property
    def why(self) -> str:
        """In words: "" when it passed as it came, "clamped", "non-finite linear.x", ..."""
        if self.acting is Acting.PASSED:
            return ""
        if self.acting is Acting.NOT_FINITE:
            return f"non-finite {self.path}"
        if self.acting is Acting.RULE_STOPPED:
            return self.path
        return "outside its limits" if self.acting is Acting.DROPPED else self.acting.value


class Guarding(Protocol):
    """What an output's endpoint (a publication, a relay) asks of the guard on its topic: a session's guard, one
    placed on a machine, or a keeper's there."""

    def check(self, msg: Any) -> Verdict:
        """What to send for ``msg``."""

    def passes_raw(self, raw: Any, encoding: str) -> bool:
        """Whether the serialized ``raw`` goes on as it came, read in its bytes (False: :meth:`check` it whole)."""


@dataclass
class GuardFigures:
    """What a guard has done so far (``%status``): messages passed, clamped, dropped, stopped in its place."""

    passed: int = 0
    clamped: int = 0
    dropped: int = 0
    replaced: int = 0  # stop messages sent in place of a message (non-finite, or e-stopped)
    last_trip: str = ""  # the last time it acted, and why
    last_trip_at: float = 0.0


class Gate:
    """Every message of one guarded output passes here first (see the module's docstring).

    ``stop()`` makes the stop message; ``estopped()`` says whether the guard holds it now (the
    session's e-stop, or its e-stop topic, read from the state it shares with its process);
    ``passed()`` is told of each message sent (its process watches the silence); ``say(text)``
    tells the prompt, once per episode and kind: an episode is a run of messages the gate acts on with
    no second of quiet between them (:data:`EPISODE_QUIET`), so a stream that alternates clamped and
    non-finite values is said in two lines, not one a message.
    Thread-safe: a handler, ``%pub`` and a relay may send at once.
    """

    def __init__(self, topic: str, cls: type, limits: dict[str, tuple[float, float]], rates: dict[str, float],
                 on_limit: str, stop: Callable[[], Any], estopped: Callable[[], bool], passed: Callable[[], None],
                 say: Callable[[str], None], clock: Callable[[], float] = time.monotonic,
                 rules: Optional[RuleSet] = None,
                 heard: Callable[[], Mapping[str, tuple[Any, float]]] = lambda: {},
                 report: Callable[[Acting, str], None] = lambda acting, what: None) -> None:
        self.topic, self.cls = topic, cls
        self._limits = [(parse_path(cls, p, topic), low, high) for p, (low, high) in limits.items()]
        self._rates = [(parse_path(cls, p, topic), most) for p, most in rates.items()]
        self._drop = on_limit == "drop"
        self._stop, self._estopped, self._passed, self._say, self._clock = stop, estopped, passed, say, clock
        self._report = report  # each kind of acting once an episode, as a value (``~guard_state``)
        self._finite = finite_checker(cls)
        self._lock = threading.Lock()
        self._last: dict[tuple[str, int], tuple[float, float]] = {}  # (path, n-th value) → (value, when) that passed
        self._said: set[Acting] = set()  # the kinds of acting said in this episode
        self._acted_at = -math.inf  # when the gate last acted on a message (its clock)
        self.figures = GuardFigures()
        self._replacing, self._replaced_at = "", -math.inf  # why the last message was replaced, and when
        self._passed_at = -math.inf  # when a command last passed
        self.commands = 0  # messages that passed as commands (as they came, or clamped): not replaced, not dropped
        #: Its rules over what the robot senses, and each input's last message and when it came (this clock).
        self._rules, self._heard = rules, heard
        self.last_command: Any = None  # the last message that passed as a command (what an idle check judges)
        self._raw_checkers: dict[str, Any] = {}  # an encoding → its check of a message's bytes (None: read whole)

    def check(self, msg: Any) -> Verdict:
        """What to send for ``msg``, which is left as it is (a clamped message is a copy of it)."""
        with self._lock:
            verdict = self._check(msg)
            if verdict.send is not None:
                self.figures.passed += 1
                self._passed()
            return verdict

    def passes_raw(self, raw: Any, encoding: str) -> bool:
        """Whether the serialized message ``raw`` passes as it came, read in its bytes (see :meth:`raw_checker`,
        made once an encoding); False: read it whole and :meth:`check` it."""
        checker = self._raw_checkers.get(encoding, self)
        if checker is self:
            checker = self._raw_checkers[encoding] = self.raw_checker(encoding)
        try:
            return checker is not None and checker(raw)
        except Exception:  # noqa: BLE001 - never a dropped command for a check of its bytes gone wrong: read it whole
            return False

    def raw_checker(self, encoding: str) -> Optional[Callable[[Any], bool]]:
        """A check of one message's serialized bytes (in ``encoding``: :data:`~ipyros.core.wire.ROS1` or
        :data:`~ipyros.core.wire.CDR`) that says whether it passes as it came (not e-stopped, every float finite,
        every limited field within its bounds), counted as :meth:`check` counts one; False: read it whole and
        :meth:`check` it. None when this gate must read every message whole: it has rules or rates (they depend on
        more than the message), a limit on a sequence's elements, or its type has no fixed layout (see
        :mod:`ipyros.core.wire`). What a guarded relay forwards unchanged, without deserialising it."""
        if self._rules is not None or self._rates:
            return None
        found = wire.layout(self.cls, encoding)
        if found is None:
            return None
        place = {name: i for i, name in enumerate(found.names)}
        if any(path.text not in place for path, _, _ in self._limits):
            return None
        limits = [(place[path.text], low, high) for path, low, high in self._limits]
        read, lock, estopped, clock, passed, figures = (found.read, self._lock, self._estopped, self._clock,
                                                        self._passed, self.figures)

        def passes(raw: Any) -> bool:  # on every message of a guarded relay: what it reads is bound once, here
            numbers = read(raw)
            if numbers is None:
                return False
            for i, low, high in limits:
                if not low <= numbers[i] <= high:
                    return False
            with lock:
                if estopped():
                    return False
                self.commands += 1
                self._passed_at = clock()
                figures.passed += 1
                passed()
            return True

        return passes

    def _check(self, msg: Any) -> Verdict:
        if self._estopped():
            self.figures.replaced += 1
            # said once by who e-stopped it (%estop, nd.estop()) or, for its e-stop topic, by the session's watch
            self._episode_of(Acting.ESTOPPED, "e-stopped: the stop message is sent in place of every message until "
                                              "released", say=False)
            return Verdict(self._stop(), Acting.ESTOPPED)
        bad = self._finite(msg)
        if bad is not None:
            self.figures.replaced += 1
            self._replacing, self._replaced_at = f"{bad} not finite", self._clock()
            self._episode_of(Acting.NOT_FINITE, f"{bad} is not a finite number: the stop message was sent in its place",
                             why=f"{bad} not finite")
            return Verdict(self._stop(), Acting.NOT_FINITE, bad)
        ruled = ""
        if self._rules is not None:
            judged = self._rules.judge(self._heard(), self._clock(), msg)
            sent, ruled, stopped = self._rules.apply(judged, msg, self._stop)
            if stopped:
                self.figures.replaced += 1
                self._replacing, self._replaced_at = ruled, self._clock()
                self._episode_of(Acting.RULE_STOPPED, f"{ruled}: the stop message was sent in its place", why=ruled)
                return Verdict(sent, Acting.RULE_STOPPED, ruled)
            msg = sent  # scaled or clamped by the rules in force (a copy), or as it came
        outside = self._outside(msg)
        if outside and self._drop:
            self.figures.dropped += 1
            path, _, _, value, _ = outside[0]
            self._episode_of(Acting.DROPPED, f"{path.text} = {value:g} is outside its limits: dropped")
            return Verdict(None, Acting.DROPPED, path.text)
        if outside or self._rates and self._ramp(msg, change=False):
            msg = copy.deepcopy(msg)  # the sender's message is left as it was
            outside = self._outside(msg)
        for path, owner, key, _, clamped in outside:
            Path.set(owner, key, _cast(path.kind, clamped))
        ramped = self._ramp(msg)
        self.commands += 1
        self._passed_at = self._clock()
        if self._rules is not None:  # a copy: the sender may change its message once sent
            self.last_command = copy_message(msg)
        if outside or ramped or ruled:
            self.figures.clamped += 1
            what = [f"{p.text} {v:g} -> {c:g}" for p, _, _, v, c in outside] + ramped + ([f"rules: {ruled}"] if ruled
                                                                                          else [])
            self._episode_of(Acting.CLAMPED, f"clamped ({', '.join(what[:3])}{' ...' if len(what) > 3 else ''})")
            return Verdict(msg, Acting.CLAMPED)
        return Verdict(msg)

    @property
    def replacing(self) -> str:
        """Why the stop message goes out in place of every message sent now ("linear.x not finite"): one was
        replaced within the last :data:`EPISODE_QUIET` s and no command passed in it; else "". The output then
        sends, but no command passes (``%status`` says "stopping", not "passing")."""
        now = self._clock()
        replacing = now - self._replaced_at < EPISODE_QUIET and now - self._passed_at >= EPISODE_QUIET
        return self._replacing if replacing else ""

    def _outside(self, msg: Any) -> list[tuple[Path, Any, Any, Any, float]]:
        """``(path, owner, key, value, clamped)`` of each value of ``msg`` outside its limits."""
        found = []
        for path, low, high in self._limits:
            for owner, key, value in path.values(msg):
                if not low <= value <= high:
                    found.append((path, owner, key, value, min(max(value, low), high)))
        return found

    def _ramp(self, msg: Any, change: bool = True) -> list[str]:
        """Hold each rate-limited field to its most change per second since the last value that passed (only
        said, not done, unless ``change``)."""
        now, done = self._clock(), []
        for path, most in self._rates:
            for place, (owner, key, value) in enumerate(path.values(msg)):  # each value of the path, in order
                last = self._last.get((path.text, place))
                target = value
                if last is not None:
                    step = most * max(now - last[1], 0.0)
                    target = min(max(value, last[0] - step), last[0] + step)
                if target != value:
                    done.append(f"{path.text} {value:g} -> {target:g} (rate)")
                    if change:
                        Path.set(owner, key, _cast(path.kind, target))
                if change:
                    self._last[(path.text, place)] = (target, now)
        return done

    def idle(self) -> str:
        """Judged with no new command (the guard's watch, a few times a second): why the stop message must go out
        now by its rules (an input gone stale, a stop rule, a last command they would now change), or ""."""
        if self._rules is None:
            return ""
        with self._lock:
            return self._rules.idle(self._heard(), self._clock(), self.last_command, self._stop)

    def stopped(self) -> None:
        """The stop message went out (the output is at rest): a rate-limited field starts again from it."""
        with self._lock:
            stop, now = self._stop(), self._clock()
            for path, _ in self._rates:
                for place, (_, _, value) in enumerate(path.values(stop)):
                    self._last[(path.text, place)] = (value, now)

    def _episode_of(self, acting: Acting, what: str, say: bool = True, why: Optional[str] = None) -> None:
        """Note that the gate acted (``what``, in words, for the prompt), said once an episode and kind of acting,
        and reported as a value with ``why`` (the reason alone; ``what`` when not given)."""
        now = self._clock()
        if now - self._acted_at >= EPISODE_QUIET:
            self._said.clear()  # a quiet second: a new episode
        self._acted_at = now
        if acting not in self._said:
            self._said.add(acting)
            self.figures.last_trip, self.figures.last_trip_at = what, time.time()
            if say:
                self._say(f"guard {self.topic}: {what}")
            self._report(acting, what if why is None else why)


class RuleWatch:
    """What a guard's rules do with no command coming, looked at by its watch a few times a second and as each input
    arrives: the one account of it for the session's guard and a keeper's on the robot.

    ``look(why, now)``, with ``why`` what :meth:`Gate.idle` says: whether the stop message goes out now (the rules
    hold it and its last went out a period of the guard's rate ago or more), and what to say once: the rules begin
    to hold it (:attr:`Acting.RULE_STOPPED`, and why), or they let commands pass again (:attr:`Acting.PASSED`). A
    last command the rules would now change is replaced by the stop message sent through the gate, which the rules
    pass: the next look finds nothing to hold, and that end is not news (no command has passed since).
    """

    def __init__(self, repeat: float) -> None:
        self.ruling = ""  # why its rules hold the stop message now ("": they do not)
        self._period = 1.0 / repeat
        self._sent_at = -math.inf
        self._lock = threading.Lock()  # a watch's look and an input's arrival, from two threads

    def due(self, why: str, now: float) -> bool:
        """Whether the stop message goes out now for ``why`` (nothing for ""), at the guard's rate."""
        with self._lock:
            if not why or now - self._sent_at < self._period:
                return False
            self._sent_at = now
            return True

    def look(self, why: str, now: float) -> tuple[bool, Optional[tuple[Acting, str]]]:
        """Whether to send the stop message now, and the change to say once, if any: its kind and why (the reason
        alone, as ``~guard_state`` publishes it; :meth:`line` puts it in words for the prompt)."""
        send = self.due(why, now)
        with self._lock:
            before, self.ruling = self.ruling, why
        if why and not before:
            return send, (Acting.RULE_STOPPED, why)
        if not why and before and not before.startswith(CHANGED_LAST):
            return send, (Acting.PASSED, RULES_PASS)
        return send, None

    @staticmethod
    def line(change: tuple[Acting, str]) -> str:
        """A change :meth:`look` found, in words."""
        acting, why = change
        return f"{why}: the stop message goes out until its rules let a command pass" \
            if acting is Acting.RULE_STOPPED else why


def _cast(kind: str, value: float) -> Any:
    return float(value) if kind in _FLOATS else int(round(value))


@dataclass(frozen=True)
class GuardState:
    """A guard as ``%status`` shows it."""

    topic: str
    state: str  # "passing", "stopped on silence", "e-stopped"
    figures: GuardFigures = field(default_factory=GuardFigures)
    stops_sent: int = 0  # by its process, on silence or e-stopped
    reach: int = 0  # subscribers of the topic its process's publisher has found: where a stop message goes
    rules: tuple[str, ...] = ()  # its rules over what the robot senses, each in words, "in force" said
