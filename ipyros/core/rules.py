"""A guard's rules over what the robot senses: conditions over message paths, and what the guard does while one holds.

A guard's limits are constants; a robot's safety rules rarely are ("no faster than 0.2 m/s when something is
closer than 0.5 m", "nothing but backing off while the bumper is pressed", "stop when the scan is older than
0.3 s"). A :class:`Rule` is data, so that it can be saved, exported and shown::

    rule("min(/scan.ranges) < 0.5", limit={"linear.x": (-0.2, 0.2)})
    rule("/bumper.state == 1", only="linear.x <= 0")
    rule("/battery.percentage < 0.1", stop=True)
    rule("/scan.ranges[0] < 0.3 or /scan.ranges[-1] < 0.3", scale=0.5, hold=1.0)

A condition is an expression over message paths of the inputs (``/topic.field``, as ``%echo`` reads them, a
path that selects many values giving their list) and the guarded message's own fields (``linear.x``): numbers,
``true``/``false``, comparisons, ``and``/``or``/``not``, ``+ - * /``, ``min``/``max``/``abs``/``len``. Nothing
else parses: no attribute that is not a field, no call but those four, no names but fields.

What a :class:`RuleSet` promises, on the messages it is given (it is pure: the gate feeds it what its
subscriptions heard, on the gate's clock):

* it fails closed: an input never heard, older than its ``stale`` time, or a condition that cannot be evaluated
  on what was heard (a field it lacks, a NaN compared, an array with no value to take the minimum of) is a stop;
* the most restrictive wins: any stop, then any ``only`` the command breaks (a stop too: the guard sends no
  command of its own making), then the smallest ``scale`` of every float field, then each field clamped to the
  intersection of the limits in force;
* a rule holds for ``hold`` seconds after its condition was last true;
* :meth:`RuleSet.idle` judges again without a command (the gate's timer): a stop, or a last command the rules
  in force would now change, is a stop, so an obstacle that appears brings the stop with no new command. A
  condition that reads the command's fields is judged against the last command then; before any command, it
  is not judged (nothing was sent: nothing to stop).

NaN in an array that ``min``/``max`` read (a laser's invalid ray) is left out of it; the array with nothing else
is a stop. A NaN compared anywhere else is a stop.
"""

from __future__ import annotations

import ast
import math
import re
from dataclasses import dataclass, field
from typing import Any, Callable, Collection, Iterable, Mapping, Optional, Sequence

from . import msgpath
from .errors import DeclarationError, cut
from .msgbuild import copy_message, field_types, nested_class

__all__ = ["CHANGED_LAST", "Condition", "Judgement", "Rule", "RuleSet", "as_rule", "compile_condition", "input_index",
           "parse_condition", "rule"]


# -- a rule, as declared --------------------------------------------------------------------------

@dataclass(frozen=True)
class Rule:
    """A condition over what the robot senses and what the guard does while it holds (see the module's docstring).
    Made by :func:`rule`, which checks its shape; the condition is checked against types by :class:`RuleSet`."""

    condition: str
    limit: tuple[tuple[str, float, float], ...] = ()  # (field path, low, high)
    scale: Optional[float] = None  # every float field times this
    only: Optional[str] = None  # a condition over the command's fields it must meet
    stop: bool = False
    hold: float = 0.0  # seconds the rule stays in force after its condition was last true

    @property
    def action(self) -> str:
        """What it does, in words: ``limit linear.x -0.2..0.2``, ``scale 0.5``, ``only linear.x <= 0``, ``stop``."""
        if self.stop:
            return "stop"
        if self.only is not None:
            return f"only {self.only}"
        if self.scale is not None:
            return f"scale {self.scale:g}"
        return "limit " + ", ".join(f"{path} {low:g}..{high:g}" for path, low, high in self.limit)

    def __str__(self) -> str:
        held = f", held {self.hold:g} s" if self.hold else ""
        return f"when {self.condition}: {self.action}{held}"

    def as_data(self) -> dict[str, Any]:
        """The rule as plain data (a model file's, a saved session's): what :func:`rule` takes."""
        data: dict[str, Any] = {"condition": self.condition}
        if self.limit:
            data["limit"] = {path: [low, high] for path, low, high in self.limit}
        if self.scale is not None:
            data["scale"] = self.scale
        if self.only is not None:
            data["only"] = self.only
        if self.stop:
            data["stop"] = True
        if self.hold:
            data["hold"] = self.hold
        return data


def _finite(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def rule(condition: Any, *, limit: Any = None, scale: Any = None, only: Any = None, stop: Any = False,
         hold: Any = 0.0) -> Rule:
    """A guard rule: while ``condition`` holds, ``limit`` the fields to bounds, ``scale`` every float field by a
    ratio (0..1), let pass ``only`` commands meeting a condition over their fields, or ``stop``; one of the four.
    ``hold`` keeps it in force that many seconds after the condition was last true. Each mistake one line."""
    where = f"rule({cut(condition)})"
    if not isinstance(condition, str) or not condition.strip():
        raise DeclarationError(f"rule({cut(condition)}): give the condition as text, e.g. "
                               "rule('min(/scan.ranges) < 0.5', limit={'linear.x': (-0.2, 0.2)})")
    actions = [name for name, given in (("limit", limit is not None), ("scale", scale is not None),
                                        ("only", only is not None), ("stop", stop is not False)) if given]
    if len(actions) != 1:
        raise DeclarationError(f"{where}: give one action, limit=, scale=, only= or stop=True"
                               + (f", not {' and '.join(actions)} (make two rules)" if actions else ""))
    bounds: list[tuple[str, float, float]] = []
    if limit is not None:
        if not isinstance(limit, dict) or not limit:
            raise DeclarationError(f"{where}: limit={cut(limit)}: give a dict of field paths and (low, high), "
                                   "e.g. limit={'linear.x': (-0.2, 0.2)}")
        for path, pair in limit.items():
            if not isinstance(path, str) or not (isinstance(pair, (tuple, list)) and len(pair) == 2
                                                 and all(map(_finite, pair)) and pair[0] <= pair[1]):
                raise DeclarationError(f"{where}: limit[{cut(path)}] = {cut(pair)}: give (low, high), two finite "
                                       "numbers with low <= high, e.g. (-0.2, 0.2)")
            bounds.append((path.strip(), float(pair[0]), float(pair[1])))
    if scale is not None and (not _finite(scale) or not 0 <= scale <= 1):
        raise DeclarationError(f"{where}: scale={cut(scale)}: give the ratio every float field is multiplied by, "
                               "from 0 to 1 (0.5: half speed, the same curve)")
    if only is not None and (not isinstance(only, str) or not only.strip()):
        raise DeclarationError(f"{where}: only={cut(only)}: give a condition over the command's fields, e.g. "
                               "only='linear.x <= 0'")
    if stop is not False and stop is not True:
        raise DeclarationError(f"{where}: stop={cut(stop)}: give stop=True")
    if not _finite(hold) or hold < 0:
        raise DeclarationError(f"{where}: hold={cut(hold)}: give the seconds the rule stays in force after its "
                               "condition ends, 0 or more")
    return Rule(condition.strip(), tuple(bounds), None if scale is None else float(scale),
                None if only is None else only.strip(), bool(stop), float(hold))


def as_rule(given: Any, where: str) -> Rule:
    """``given`` as a :class:`Rule`: one already, or its data (a saved file's, a model file's: :meth:`Rule.as_data`,
    the keywords of :func:`rule`); anything else, one line."""
    if isinstance(given, Rule):
        return given
    if isinstance(given, dict):
        unknown = set(given) - {"condition", "limit", "scale", "only", "stop", "hold"}
        if unknown or "condition" not in given:
            raise DeclarationError(f"{where}: a rule as data holds condition= and one of limit=, scale=, only=, "
                                   f"stop=, and hold=, not {cut(sorted(unknown) or given)}")
        data = dict(given)
        return rule(data.pop("condition"), **data)
    raise DeclarationError(f"{where}: {cut(given)} is not a rule; make each with rule(condition, ...), e.g. "
                           "rule('/bumper.state == 1', only='linear.x <= 0')")


# -- conditions, compiled -------------------------------------------------------------------------

class RuleValueError(Exception):
    """A condition could not be evaluated on what was heard: the guard stops (the words say why)."""


#: How the rules' judging with no command coming begins when the last command that passed would now be changed.
CHANGED_LAST = "the last command would now be changed"
#: A topic's path in a condition: a ``/`` where no value ends (not a division), then a name.
_PATH = re.compile(r"/[A-Za-z_][\w/]*(?:\.[A-Za-z_]\w*|\[-?\d*:?-?\d*\])*")
#: What a value ends with (a division follows it): a name or number that is no keyword, a ")" or a "]".
_ENDS_VALUE = re.compile(r"(?:[)\]]|(?<![\w.])(?!(?:and|or|not)\s*$)[\w.]+)\s*$")
_FUNCTIONS = {"min", "max", "abs", "len"}
_COMPARE: dict[type, Callable[[Any, Any], bool]] = {
    ast.Eq: lambda a, b: a == b, ast.NotEq: lambda a, b: a != b, ast.Lt: lambda a, b: a < b,
    ast.LtE: lambda a, b: a <= b, ast.Gt: lambda a, b: a > b, ast.GtE: lambda a, b: a >= b}
_ARITHMETIC: dict[type, Callable[[Any, Any], Any]] = {
    ast.Add: lambda a, b: a + b, ast.Sub: lambda a, b: a - b, ast.Mult: lambda a, b: a * b,
    ast.Div: lambda a, b: a / b}
_WHAT = ("conditions use numbers, true/false, comparisons, and/or/not, + - * /, min max abs len, message paths "
         "(/scan.ranges) and the command's fields (linear.x)")

#: What a compiled part is handed: the values of the input paths, in order, and the command (None: none).
Env = tuple[Sequence[Any], Any]


@dataclass(frozen=True)
class Condition:
    """A condition compiled once: ``inputs`` the message paths it reads (their topics are the rule's inputs),
    ``fields`` the command's fields it reads; :meth:`holds` evaluates it."""

    text: str
    inputs: tuple[msgpath.MessagePath, ...]
    fields: tuple[str, ...]
    _run: Callable[[Env], Any] = field(repr=False, compare=False)

    def holds(self, values: Sequence[Any], command: Any = None) -> bool:
        """Whether it holds, given each input path's value (in :attr:`inputs`' order) and the command; a
        :class:`RuleValueError` when it cannot be told (a NaN, a missing field, not a true/false)."""
        try:
            found = self._run((values, command))
        except RuleValueError:
            raise
        except (AttributeError, IndexError, TypeError, ValueError, ZeroDivisionError) as error:
            raise RuleValueError(f"{self.text}: {type(error).__name__}: {error}") from None
        if not isinstance(found, bool):
            raise RuleValueError(f"{self.text}: gave {cut(found)}, not true or false")
        return found


def compile_condition(text: str, where: str, inputs: bool = True, fields: bool = True) -> Condition:
    """``text`` compiled (see the module's docstring): a one-line :class:`DeclarationError` for a syntax error
    (with its column), anything a condition may not hold, or what is not a true/false at its top."""
    top, paths = parse_condition(text, where, inputs)
    read: list[str] = []
    run = _Compiler(text, where, paths, read, fields).compile(top)
    if not (isinstance(top, (ast.Compare, ast.BoolOp, ast.Name, ast.Attribute, ast.Subscript))
            or isinstance(top, ast.UnaryOp) and isinstance(top.op, ast.Not)
            or isinstance(top, ast.Constant) and isinstance(top.value, bool)):
        raise DeclarationError(f"{where}: {text!r} is not a true/false condition; compare it, e.g. "
                               f"{text.strip()} > 0")
    return Condition(text, tuple(paths), tuple(dict.fromkeys(read)), run)


def parse_condition(text: str, where: str, inputs: bool = True) -> tuple[ast.expr, list[msgpath.MessagePath]]:
    """``text`` parsed, not yet checked (:func:`compile_condition` checks it): Python's tree of the expression, each
    message path in it a name ``_p0``, ``_p1``... (padded with ``_`` to the path's length, so that a syntax error's
    column is the user's) standing for the paths returned, in order. An exported node renders the same tree."""
    paths: list[msgpath.MessagePath] = []
    spelled = []
    last = 0
    for found in _PATH.finditer(text):
        if _ENDS_VALUE.search(text[:found.start()]):
            continue  # a division: "speed/2"
        if not inputs:
            raise DeclarationError(f"{where}: {found.group(0)!r}: this condition reads the command's fields "
                                   "only (linear.x), not a topic")
        try:
            paths.append(msgpath.parse(found.group(0)))
        except msgpath.MessagePathError as error:
            raise DeclarationError(f"{where}: {error}") from None
        name = f"_p{len(paths) - 1}"
        spelled += [text[last:found.start()], name.ljust(len(found.group(0)), "_")]
        last = found.end()
    spelled.append(text[last:])
    source = re.sub(r"\btrue\b", "True", re.sub(r"\bfalse\b", "False", "".join(spelled)))
    try:
        return ast.parse(source.strip(), mode="eval").body, paths
    except SyntaxError as error:
        at = "at its end" if not error.offset or error.offset > len(source.strip()) else \
            f"at column {error.offset + len(source) - len(source.lstrip())}"
        raise DeclarationError(f"{where}: {text!r} does not parse {at}: {error.msg}; {_WHAT}") from None


def input_index(name: str) -> Optional[int]:
    """Which input path a name of :func:`parse_condition`'s tree stands for (``_p1__`` → 1); None: a field's name."""
    return int(name.strip("_").removeprefix("p")) if re.fullmatch(r"_p\d+_*", name) else None


class _Compiler:
    """An expression's tree turned into nested closures, each node checked against what a condition may hold."""

    def __init__(self, text: str, where: str, paths: list[msgpath.MessagePath], read: list[str],
                 fields: bool) -> None:
        self.text, self.where, self.paths, self.read, self.fields = text, where, paths, read, fields

    def refuse(self, node: ast.AST, what: str) -> DeclarationError:
        return DeclarationError(f"{self.where}: {self.text!r}: {what} (column {getattr(node, 'col_offset', 0) + 1}); "
                                f"{_WHAT}")

    def compile(self, node: ast.AST) -> Callable[[Env], Any]:  # noqa: C901 - one case a kind of node
        if isinstance(node, ast.Constant):
            value = node.value
            if isinstance(value, bool) or _finite(value):
                return lambda env: value
            raise self.refuse(node, f"{value!r} is not a number or true/false")
        index = input_index(node.id) if isinstance(node, ast.Name) else None
        if index is not None:
            return lambda env: env[0][index]
        if isinstance(node, (ast.Name, ast.Attribute, ast.Subscript)):
            return self.command_field(node)
        if isinstance(node, ast.BoolOp):
            parts = [self.compile(value) for value in node.values]
            if isinstance(node.op, ast.And):
                return lambda env: all(_truth(part(env)) for part in parts)
            return lambda env: any(_truth(part(env)) for part in parts)
        if isinstance(node, ast.UnaryOp):
            operand = self.compile(node.operand)
            if isinstance(node.op, ast.Not):
                return lambda env: not _truth(operand(env))
            if isinstance(node.op, ast.USub):
                return lambda env: -_number(operand(env))
            if isinstance(node.op, ast.UAdd):
                return lambda env: _number(operand(env))
        if isinstance(node, ast.BinOp) and type(node.op) in _ARITHMETIC:
            left, right, apply = self.compile(node.left), self.compile(node.right), _ARITHMETIC[type(node.op)]
            return lambda env: apply(_number(left(env)), _number(right(env)))
        if isinstance(node, ast.Compare) and all(type(op) in _COMPARE for op in node.ops):
            terms = [self.compile(node.left), *(self.compile(c) for c in node.comparators)]
            ops = [_COMPARE[type(op)] for op in node.ops]
            return lambda env: _compare(terms, ops, env)
        if isinstance(node, ast.Call):
            name = node.func.id if isinstance(node.func, ast.Name) else ""
            if name not in _FUNCTIONS or node.keywords or not node.args:
                raise self.refuse(node, f"a call of {ast.unparse(node.func)!r}")
            args = [self.compile(arg) for arg in node.args]
            return _function(name, args)
        raise self.refuse(node, f"{ast.unparse(node)!r} is not allowed")

    def command_field(self, node: ast.AST) -> Callable[[Env], Any]:
        """``linear.x``, ``axes[2]``: a field of the guarded command, read by its steps."""
        steps: list[Any] = []
        at = node
        while not isinstance(at, ast.Name):
            if isinstance(at, ast.Attribute) and not at.attr.startswith("_"):
                steps.append(at.attr)
                at = at.value
            elif (isinstance(at, ast.Subscript) and isinstance(at.slice, ast.Constant)
                  and isinstance(at.slice.value, int) and not isinstance(at.slice.value, bool)):
                steps.append(at.slice.value)
                at = at.value
            else:
                raise self.refuse(at, f"{ast.unparse(at)!r} is not a field")
        if at.id in _FUNCTIONS or at.id.startswith("_"):
            raise self.refuse(at, f"{at.id!r} is not a field")
        if not self.fields:
            raise self.refuse(node, f"{ast.unparse(node)!r}: the command's fields are read by only= and the rule's "
                                    "conditions of the command, not here")
        steps.append(at.id)
        steps.reverse()
        self.read.append(ast.unparse(node))

        def value(env: Env) -> Any:
            found = env[1]
            if found is None:
                raise RuleValueError(f"{ast.unparse(node)}: no command to read it from")
            for step in steps:
                found = found[step] if isinstance(step, int) else getattr(found, step)
            return found

        return value


def _truth(value: Any) -> bool:
    if not isinstance(value, bool):
        raise RuleValueError(f"{cut(value)} is not true or false")
    return value


def _number(value: Any) -> Any:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise RuleValueError(f"{cut(value)} is not a number")
    if value != value:
        raise RuleValueError("a NaN")
    return value


def _compare(terms: list[Callable[[Env], Any]], ops: list[Callable[[Any, Any], bool]], env: Env) -> bool:
    left = terms[0](env)
    for op, term in zip(ops, terms[1:]):
        right = term(env)
        for value in (left, right):
            if isinstance(value, float) and value != value:
                raise RuleValueError("a NaN compared")
        if not op(left, right):
            return False
        left = right
    return True


def _function(name: str, args: list[Callable[[Env], Any]]) -> Callable[[Env], Any]:
    def values(env: Env) -> Sequence[Any]:
        found = [arg(env) for arg in args]
        if len(found) == 1 and hasattr(found[0], "__len__") and not isinstance(found[0], (str, bytes)):
            return found[0]  # one array (a list, a tuple, array.array, numpy): its elements, not copied
        return found

    if name == "len":
        return lambda env: len(args[0](env)) if len(args) == 1 else _raise(f"len takes one array, not {len(args)}")
    if name == "abs":
        return lambda env: abs(_number(args[0](env))) if len(args) == 1 else _raise("abs takes one number")
    pick = min if name == "min" else max

    def extreme(env: Env) -> Any:
        found = values(env)
        try:
            # At C's speed: a NaN after the first element is never picked (it compares false), so a float that is
            # not NaN is the extreme of the numbers that are not NaN; anything else is judged one by one below.
            quick = pick(found) if len(found) else None
        except TypeError:
            quick = None
        if isinstance(quick, float) and quick == quick:
            return quick
        numbers = [_number(v) for v in found if not (isinstance(v, float) and v != v)]  # a NaN ray: none
        if not numbers:
            raise RuleValueError(f"{name} of no value (nothing but NaN, or empty)")
        return pick(numbers)

    return extreme


def _raise(text: str) -> Any:
    raise RuleValueError(text)


# -- the rules of one guard, judged -------------------------------------------------------------

@dataclass(frozen=True)
class Judgement:
    """What the rules in force make of one command (or of none: the gate's timer), as values.

    ``stop``: why the stop message goes out instead ("" when it does not); ``limits``: each field's bounds in
    force (their intersection); ``scale``: the ratio in force (1.0: none); ``acting``: the rules in force, by
    number (1 = the first given), for ``%status`` and a guard's state topic."""

    stop: str = ""
    limits: tuple[tuple[str, float, float], ...] = ()
    scale: float = 1.0
    acting: tuple[int, ...] = ()
    only: tuple[tuple[int, Condition], ...] = ()


class RuleSet:
    """The rules of one guard, compiled against the guarded type ``cls`` (each limit's field checked, each
    ``only``'s fields), their inputs' topics and ``stale`` times (seconds; a topic without one is only required
    to have been heard). Not thread-safe: the gate calls it under its lock."""

    def __init__(self, rules: Sequence[Rule], cls: Optional[type], output: str, stale: Mapping[str, float],
                 where: str, types: Optional[Mapping[str, Any]] = None) -> None:
        self.rules = tuple(rules)
        self.conditions: list[Condition] = []
        self.onlys: list[Optional[Condition]] = []
        for number, given in enumerate(self.rules, 1):
            here = f"{where}: rule {number}"
            if not isinstance(given, Rule):
                raise DeclarationError(f"{here}: {cut(given)} is not a rule; make each with rule(condition, ...)")
            condition = compile_condition(given.condition, here)
            for path in condition.inputs:
                if path.topic == output:
                    raise DeclarationError(f"{here}: {path.text} reads the guarded output itself; a rule reads "
                                           "what the robot senses (/scan, /bumper), and the command by its fields "
                                           "(linear.x)")
                cls_there = (types or {}).get(path.topic)
                if cls_there is not None:
                    try:
                        path.check(cls_there)
                    except msgpath.MessagePathError as error:
                        raise DeclarationError(f"{here}: {error}") from None
            if cls is not None:
                for text in condition.fields:
                    _check_field(cls, text, here)
                for text, _, _ in given.limit:
                    _check_field(cls, text, here, number=True)
            self.conditions.append(condition)
            only = compile_condition(given.only, f"{here} only=", inputs=False) if given.only is not None else None
            if only is not None and cls is not None:
                for text in only.fields:
                    _check_field(cls, text, here)
            self.onlys.append(only)
        for topic, seconds in stale.items():
            if not isinstance(topic, str) or not topic.startswith("/") or not _finite(seconds) or seconds <= 0:
                raise DeclarationError(f"{where}: stale[{cut(topic)}] = {cut(seconds)}: give a topic ('/scan') and "
                                       "the seconds after which its last message is too old, above 0")
        self.stale = {topic: float(seconds) for topic, seconds in stale.items()}
        self.topics = tuple(dict.fromkeys([p.topic for c in self.conditions for p in c.inputs] + list(self.stale)))
        self.floats = _float_paths(cls) if cls is not None else None
        self._held_until = [-math.inf] * len(self.rules)
        self.acting: tuple[int, ...] = ()  # the rules in force at the last judgement, by number

    def judge(self, heard: Mapping[str, tuple[Any, float]], now: float, command: Any = None) -> Judgement:
        """What the rules make of ``command`` (or of none), given each input topic's last message and when it
        came (``heard``), at ``now`` (the same clock); the rules in force are kept in :attr:`acting`."""
        judgement = self._judge(heard, now, command)
        self.acting = judgement.acting
        return judgement

    def described(self, acting: Optional[Collection[int]] = None) -> tuple[str, ...]:
        """Each rule in words, numbered, those in force at the last judgement said so (``%status``); ``acting``: the
        numbers in force where they are judged elsewhere (a guard placed on a machine: its keeper's report)."""
        acting = self.acting if acting is None else acting
        return tuple(f"{n}. {r}" + (" (in force)" if n in acting else "") for n, r in enumerate(self.rules, 1))

    def _judge(self, heard: Mapping[str, tuple[Any, float]], now: float, command: Any) -> Judgement:
        for topic in self.topics:
            got = heard.get(topic)
            if got is None:
                return Judgement(stop=f"{topic} not heard yet")
            most = self.stale.get(topic)
            if most is not None and now - got[1] > most:
                return Judgement(stop=f"{topic} stale ({now - got[1]:.2f} s old, at most {most:g} s)")
        acting: list[int] = []
        limits: dict[str, tuple[float, float]] = {}
        scale = 1.0
        onlys: list[tuple[int, Condition]] = []
        for index, (given, condition) in enumerate(zip(self.rules, self.conditions)):
            number = index + 1
            if command is None and condition.fields:
                continue  # it is about a command, and there is none (nothing was sent: nothing to stop)
            try:
                values = [_value(path, heard[path.topic][0]) for path in condition.inputs]
                holds = condition.holds(values, command)
            except RuleValueError as error:
                return Judgement(stop=f"rule {number} could not be told ({error})", acting=(number,))
            if holds:
                self._held_until[index] = now + given.hold
            elif now >= self._held_until[index]:
                continue
            acting.append(number)
            if given.stop:
                return Judgement(stop=f"rule {number}: {given.condition}", acting=tuple(acting))
            if given.scale is not None:
                scale = min(scale, given.scale)
            only = self.onlys[index]
            if only is not None:
                onlys.append((number, only))
            for path, low, high in given.limit:
                was = limits.get(path, (-math.inf, math.inf))
                limits[path] = (max(was[0], low), min(was[1], high))
        bounds = tuple((path, low, high) for path, (low, high) in limits.items())
        return Judgement(limits=bounds, scale=scale, acting=tuple(acting), only=tuple(onlys))

    def apply(self, judgement: Judgement, command: Any, stop: Callable[[], Any]) -> tuple[Any, str, bool]:
        """The message to send for ``command`` under ``judgement``, why it changed ("" when it did not), and
        whether it is the stop message (a stop, an ``only`` broken) rather than a copy scaled then clamped.
        ``command`` is left as it is."""
        if judgement.stop:
            return stop(), judgement.stop, True
        for number, only in judgement.only:
            try:
                if not only.holds((), command):
                    return stop(), f"rule {number}: only {only.text}", True
            except RuleValueError as error:
                return stop(), f"rule {number}: only {only.text} could not be told ({error})", True
        if judgement.scale == 1.0 and not judgement.limits:
            return command, "", False
        try:
            return self._changed(judgement, command, stop)
        except (RuleValueError, AttributeError, IndexError, TypeError, ValueError) as error:  # fails closed
            return stop(), f"rules {', '.join(map(str, judgement.acting))} could not be applied ({error})", True

    def _changed(self, judgement: Judgement, command: Any, stop: Callable[[], Any]) -> tuple[Any, str, bool]:
        """A copy of ``command`` scaled, then clamped to the limits in force (see :meth:`apply`)."""
        out = copy_message(command)
        changed = []
        if judgement.scale != 1.0 and self.floats:
            for path in self.floats:
                for owner, key, value in _places(out, path):
                    _set(owner, key, value * judgement.scale)
            changed.append(f"scaled {judgement.scale:g}")
        for text, low, high in judgement.limits:
            if low > high:
                return stop(), f"rules {', '.join(map(str, judgement.acting))}: {text}'s limits leave no value", True
            for owner, key, value in _places(out, _steps(text)):
                if not low <= value <= high:
                    _set(owner, key, type(value)(min(max(value, low), high)))
                    changed.append(f"{text} {value:g} -> {min(max(value, low), high):g}")
        return out, ", ".join(changed), False

    def idle(self, heard: Mapping[str, tuple[Any, float]], now: float, last: Any, stop: Callable[[], Any]) -> str:
        """Judged with no new command (the gate's timer): why the stop message must go out now, or "". ``last``:
        the last command that passed (None: none yet); one the rules in force would now change is a stop (the
        guard sends no command of its own making)."""
        judgement = self.judge(heard, now, last)
        if judgement.stop:
            return judgement.stop
        if last is None:
            return ""
        _, why, _ = self.apply(judgement, last, stop)
        return f"{CHANGED_LAST} ({why})" if why else ""

    def check_stop(self, stop: Any, where: str) -> None:
        """Refuse a stop message the rules would not pass as it is: outside a rule's limits, or breaking a rule's
        ``only`` (the e-stop and the stop on silence send it unchanged, whatever rule is in force)."""
        for number, given in enumerate(self.rules, 1):
            for text, low, high in given.limit:
                for _, _, value in _places(stop, _steps(text)):
                    if not low <= value <= high:
                        raise DeclarationError(f"{where}: the stop message has {text} = {value:g}, outside rule "
                                               f"{number}'s limit {low:g}..{high:g}; give stop= within it")
            only = self.onlys[number - 1]
            if only is not None:
                try:
                    ok = only.holds((), stop)
                except RuleValueError as error:
                    raise DeclarationError(f"{where}: rule {number}'s only={only.text!r} cannot be told of the "
                                           f"stop message ({error})") from None
                if not ok:
                    raise DeclarationError(f"{where}: the stop message breaks rule {number}'s only={only.text!r}; "
                                           "give stop= that meets it")


def _value(path: msgpath.MessagePath, msg: Any) -> Any:
    """What a path gives a condition: its one value, or the list of what a slice or a filter selects."""
    try:
        found = path.values(msg)
    except msgpath.MessagePathError as error:  # a message of another type than the rule reads
        raise RuleValueError(str(error)) from None
    many = any(isinstance(step, (msgpath.Slice, msgpath.Filter)) for step in path.steps)
    if many:
        return found
    if len(found) != 1:
        raise RuleValueError(f"{path.text}: {'nothing' if not found else 'several values'} in the last message")
    return found[0]


def _check_field(cls: type, text: str, where: str, number: bool = False) -> None:
    """Say at declaration if the guarded type has no such field (and which it has), or, for a limit, no number."""
    current: Any = cls
    kind = ""
    for part in text.split("."):
        name = re.sub(r"\[-?\d+\]$", "", part)
        if current is None:
            raise DeclarationError(f"{where}: {text!r}: {kind} has no fields")
        names, kinds = field_types(current)
        if name not in names:
            raise DeclarationError(f"{where}: {text!r}: no field {name!r} in the command (it has "
                                   f"{', '.join(names) or 'none'})")
        kind = kinds[names.index(name)]
        if name != part:
            kind = re.sub(r"\[\d*\]$", "", kind)
        current = nested_class(kind)
    if number and kind not in _NUMBERS:
        raise DeclarationError(f"{where}: {text!r} is a {kind}, not a number: a limit bounds numbers")


_NUMBERS = {"float32", "float64", "int8", "int16", "int32", "int64", "uint8", "uint16", "uint32", "uint64",
            "byte", "char"}


def _steps(text: str) -> list[Any]:
    steps: list[Any] = []
    for part in text.split("."):
        indexed = re.fullmatch(r"(?P<name>\w+)\[(?P<index>-?\d+)\]", part)
        steps += [indexed["name"], int(indexed["index"])] if indexed else [part]
    return steps


def _places(msg: Any, steps: Sequence[Any]) -> Iterable[tuple[Any, Any, Any]]:
    """``(owner, key, value)`` of the value ``steps`` name in ``msg`` (none when an index is out of range)."""
    owner, key = None, None
    at = msg
    for step in steps:
        owner, key = at, step
        if isinstance(step, int):
            if not -len(at) <= step < len(at):
                return []
            at = at[step]
        else:
            at = getattr(at, step)
    return [(owner, key, at)]


def _set(owner: Any, key: Any, value: Any) -> None:
    if isinstance(key, int):
        if isinstance(owner, tuple):
            raise RuleValueError("a fixed array given as a tuple")
        owner[key] = value
    else:
        setattr(owner, key, value)


def _float_paths(cls: type, prefix: tuple[str, ...] = ()) -> list[tuple[str, ...]]:
    """The paths of every float field (not in arrays) of ``cls``: what ``scale`` multiplies."""
    found = []
    names, kinds = field_types(cls)
    for name, kind in zip(names, kinds):
        if kind in ("float32", "float64"):
            found.append((*prefix, name))
        elif "[" not in kind and kind not in _NUMBERS and kind not in ("bool", "string", "time", "duration"):
            nested = nested_class(kind)
            if nested is not None:
                found += _float_paths(nested, (*prefix, name))
    return found
