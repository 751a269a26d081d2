"""A guard's rules in an exported node: the conditions rendered as Python, and the judging they need, standing alone.

The session judges rules with :class:`ipyros.core.rules.RuleSet`; an exported node runs without ipyros, so it gets
the same judging as plain Python (:data:`RULES_FUNCTIONS`) and each condition rendered from the tree the session
compiled (:func:`ipyros.core.rules.parse_condition`): nothing is run that the session did not accept. What it
promises is the session's (see :mod:`ipyros.core.rules`): an input never heard, older than its ``stale`` time, or a
rule that cannot be told is the stop message; the most restrictive of the rules in force wins; a rule stays in
force ``hold`` seconds; judged on each command and, with none coming, at the guard's rate and as each input comes.
A unit test holds the two to the same verdicts on hostile inputs (tests/unit/files/test_exportrules.py).
"""

from __future__ import annotations

import ast
from typing import Any, Callable, Mapping

from ..core import msgpath
from ..core.errors import IpyrosError
from ..core.model import GuardModel
from ..core.rules import RuleSet, as_rule, input_index, parse_condition

__all__ = ["RULES_FUNCTIONS", "condition_source", "rules_source"]

#: The judging of a guard's rules in an exported node: plain Python, the same for rospy and rclpy (it uses math).
RULES_FUNCTIONS = '''
class RuleError(Exception):
    """A rule that cannot be told on what was heard (a NaN, a field missing, not a true/false): the stop message."""


class Rules:
    """A guard's rules over what the robot senses, judged as the session judged them (ipyros.core.rules): an input
    never heard, older than its stale time, or a rule that cannot be told is the stop message; of the rules in
    force, any stop, then any only the command breaks, then the smallest scale, then the limits' intersection; a
    rule stays in force hold s after its condition was last true. Not thread-safe: the guard calls it under its lock."""

    def __init__(self, rules, stale, inputs, floats):
        self.rules = [{"command": False, "stop": False, "scale": None, "only": None, "only_text": None, "limit": [],
                       "hold": 0.0, **rule} for rule in rules]
        self.stale, self.inputs, self.floats = stale, inputs, floats
        self.topics = list(dict.fromkeys([p[0] for r in rules for p in r["paths"]] + list(stale)))
        self._held = [-math.inf] * len(rules)

    def judge(self, heard, now, command):
        """Why the stop message goes out ("" if not), and the limits, scale and onlys of the rules in force."""
        for topic in self.topics:
            got = heard.get(topic)
            if got is None:
                return f"{topic} not heard yet", None
            most = self.stale.get(topic)
            if most is not None and now - got[1] > most:
                return f"{topic} stale ({now - got[1]:.2f} s old, at most {most:g} s)", None
        limits, scale, onlys = {}, 1.0, []
        for index, rule in enumerate(self.rules):
            if command is None and rule["command"]:
                continue  # it is about a command, and there is none (nothing was sent: nothing to stop)
            try:
                values = [_input(heard[topic][0], steps, many, text) for topic, steps, many, text in rule["paths"]]
                holds = _holds(rule["when"], values, command)
            except RuleError as error:
                return f"rule {index + 1} could not be told ({error})", None
            if holds:
                self._held[index] = now + rule["hold"]
            elif now >= self._held[index]:
                continue
            if rule["stop"]:
                return f"rule {index + 1}: {rule['text']}", None
            if rule["scale"] is not None:
                scale = min(scale, rule["scale"])
            if rule["only"] is not None:
                onlys.append((index + 1, rule["only"], rule["only_text"]))
            for path, low, high in rule["limit"]:
                was = limits.get(path, (-math.inf, math.inf))
                limits[path] = (max(was[0], low), min(was[1], high))
        return "", (limits, scale, onlys)

    def apply(self, judged, command):
        """What the rules in force make of command: (the message to send, or None for the stop message; why)."""
        limits, scale, onlys = judged
        for number, only, text in onlys:
            try:
                if not _holds(only, (), command):
                    return None, f"rule {number}: only {text}"
            except RuleError as error:
                return None, f"rule {number}: only {text} could not be told ({error})"
        if scale == 1.0 and not limits:
            return command, ""
        out, changed = copy.deepcopy(command), []
        try:
            if scale != 1.0:
                for steps in self.floats:
                    owner, key, value = _place(out, steps)
                    _set(owner, key, value * scale)
                changed.append(f"scaled {scale:g}")
            for text, (low, high) in limits.items():
                if low > high:
                    return None, f"{text}'s limits leave no value"
                for owner, key, value in _places(out, text):
                    if not low <= value <= high:
                        _set(owner, key, type(value)(min(max(value, low), high)))
                        changed.append(f"{text} {value:g} -> {min(max(value, low), high):g}")
        except (RuleError, AttributeError, IndexError, TypeError, ValueError) as error:  # fails closed
            return None, f"the rules could not be applied ({error})"
        return out, ", ".join(changed)

    def idle(self, heard, now, last):
        """Judged with no new command: why the stop message goes out now ("" if not); a last command the rules in
        force would now change is a stop (the guard sends no command of its own making)."""
        why, judged = self.judge(heard, now, last)
        if why or last is None:
            return why
        sent, why = self.apply(judged, last)
        return f"the last command would now be changed ({why})" if why else ""


def _holds(when, values, command):
    try:
        found = when(values, command)
    except RuleError:
        raise
    except (AttributeError, IndexError, TypeError, ValueError, ZeroDivisionError) as error:
        raise RuleError(f"{type(error).__name__}: {error}") from None
    if not isinstance(found, bool):
        raise RuleError(f"gave {found!r}, not true or false")
    return found


def _input(msg, steps, many, text):
    """What a message path gives a condition: its one value, or the list a slice selects."""
    found = [msg]
    for step in steps:
        out = []
        for value in found:
            if step[0] == "field":
                if isinstance(value, (list, tuple, str, bytes)) or step[1] not in _fields(value):
                    raise RuleError(f"{text}: no field {step[1]!r} here")
                out.append(getattr(value, step[1]))
                continue
            if isinstance(value, str) or not hasattr(value, "__len__"):
                raise RuleError(f"{text}: {value!r} is not an array")
            if step[0] == "index":
                out += [value[step[1]]] if -len(value) <= step[1] < len(value) else []
            else:  # ("slice", start, stop)
                out += list(value[step[1]:step[2]])
        found = out
    if many:
        return found
    if len(found) != 1:
        raise RuleError(f"{text}: {'nothing' if not found else 'several values'} in the last message")
    return found[0]


_OPS = {"==": lambda a, b: a == b, "!=": lambda a, b: a != b, "<": lambda a, b: a < b,
        "<=": lambda a, b: a <= b, ">": lambda a, b: a > b, ">=": lambda a, b: a >= b}


def _truth(value):
    if not isinstance(value, bool):
        raise RuleError(f"{value!r} is not true or false")
    return value


def _number(value):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise RuleError(f"{value!r} is not a number")
    if value != value:
        raise RuleError("a NaN")
    return value


def _compare(terms, ops):
    left = terms[0]()
    for op, term in zip(ops, terms[1:]):
        right = term()
        if any(isinstance(v, float) and v != v for v in (left, right)):
            raise RuleError("a NaN compared")
        if not _OPS[op](left, right):
            return False
        left = right
    return True


def _extreme(pick, found):
    if len(found) == 1 and hasattr(found[0], "__len__") and not isinstance(found[0], (str, bytes)):
        found = found[0]  # one array: its elements
    numbers = [_number(v) for v in found if not (isinstance(v, float) and v != v)]  # a NaN ray: none
    if not numbers:
        raise RuleError(f"{pick.__name__} of no value (nothing but NaN, or empty)")
    return pick(numbers)


def _fail(text):
    raise RuleError(text)


def _field(command, steps, text):
    if command is None:
        raise RuleError(f"{text}: no command to read it from")
    for step in steps:
        command = command[step] if isinstance(step, int) else getattr(command, step)
    return command


def _place(msg, steps):
    owner, key = None, None
    for step in steps:
        owner, key = msg, step
        msg = msg[step] if isinstance(step, int) else getattr(msg, step)
    return owner, key, msg


def _places(msg, text):
    """(owner, key, value) of the value a limit's path (linear.x, axes[2]) names; none if an index is out of range."""
    steps = []
    for part in text.split("."):
        name, _, index = part.partition("[")
        steps += [name, int(index.rstrip("]"))] if index else [name]
    try:
        return [_place(msg, steps)]
    except IndexError:
        return []


def _set(owner, key, value):
    if isinstance(key, int):
        if isinstance(owner, tuple):
            raise RuleError("a fixed array given as a tuple")
        owner[key] = value
    else:
        setattr(owner, key, value)
'''

#: What a rule's data in the exported node leaves out (:data:`RULES_FUNCTIONS`' Rules fills it in).
_DEFAULTS = {"command": ("False",), "stop": ("False",), "scale": ("None",), "only": ("None",), "only_text": ("None",),
             "limit": ("[]",), "hold": ("0.0",)}
_ARITHMETIC = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/"}
_COMPARE = {ast.Eq: "==", ast.NotEq: "!=", ast.Lt: "<", ast.LtE: "<=", ast.Gt: ">", ast.GtE: ">="}


def condition_source(text: str, where: str, inputs: bool = True) -> str:
    """A condition (already accepted by :class:`RuleSet`) as the source of a Python function of ``(v, c)``: ``v`` the
    values of its input paths in order, ``c`` the command (None: none), using :data:`RULES_FUNCTIONS`' helpers."""
    top, _ = parse_condition(text, where, inputs)
    return f"lambda v, c: {_Render().render(top)}"


class _Render:
    """A condition's tree as Python source that evaluates as :class:`ipyros.core.rules.Condition` does: the same
    order, the same checks (a number where one is wanted, a true/false where one is), the same errors as stops."""

    def render(self, node: ast.AST) -> str:  # noqa: C901 - one case a kind of node, as rules._Compiler
        if isinstance(node, ast.Constant):
            return repr(node.value)
        if isinstance(node, ast.Name) and input_index(node.id) is not None:
            return f"v[{input_index(node.id)}]"
        if isinstance(node, (ast.Name, ast.Attribute, ast.Subscript)):
            return self.field(node)
        if isinstance(node, ast.BoolOp):
            joint = " and " if isinstance(node.op, ast.And) else " or "
            return "(" + joint.join(f"_truth({self.render(value)})" for value in node.values) + ")"
        if isinstance(node, ast.UnaryOp):
            operand = self.render(node.operand)
            if isinstance(node.op, ast.Not):
                return f"(not _truth({operand}))"
            return f"(-_number({operand}))" if isinstance(node.op, ast.USub) else f"_number({operand})"
        if isinstance(node, ast.BinOp):
            left, right = self.render(node.left), self.render(node.right)
            return f"(_number({left}) {_ARITHMETIC[type(node.op)]} _number({right}))"
        if isinstance(node, ast.Compare):
            terms = ", ".join(f"lambda: {self.render(term)}" for term in [node.left, *node.comparators])
            return f"_compare(({terms},), {tuple(_COMPARE[type(op)] for op in node.ops)!r})"
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
            args = [self.render(arg) for arg in node.args]
            name = node.func.id
            if name in ("len", "abs") and len(args) != 1:
                return f"_fail({f'{name} takes one value, not {len(args)}'!r})"
            if name == "len":
                return f"len({args[0]})"
            if name == "abs":
                return f"abs(_number({args[0]}))"
            return f"_extreme({name}, [{', '.join(args)}])"
        raise IpyrosError(f"cannot export the condition part {ast.unparse(node)!r}")  # RuleSet refused it first

    @staticmethod
    def field(node: ast.AST) -> str:
        steps: list[Any] = []
        at = node
        while not isinstance(at, ast.Name):
            if isinstance(at, ast.Attribute):
                steps.append(at.attr)
                at = at.value
            else:
                assert isinstance(at, ast.Subscript) and isinstance(at.slice, ast.Constant)
                steps.append(at.slice.value)
                at = at.value
        steps.append(at.id)
        return f"_field(c, {tuple(reversed(steps))!r}, {ast.unparse(node)!r})"


def rules_source(guard: GuardModel, cls: type, name_of: Callable[[str], str], types: Mapping[str, str]) -> str:
    """The exported node's ``Rules(...)`` for ``guard`` on messages of ``cls``: each rule as data with its
    condition rendered (:func:`condition_source`), and each input's class by the script's name for it
    (``name_of``, given each input's type in ``types``: the live graph's at export, or one line if it has none)."""
    where = f"guard {guard.resolved}"
    rules = [as_rule(given, where) for given in guard.rules]
    ruleset = RuleSet(rules, cls, guard.resolved, guard.stale, where)  # what the session accepted, checked again
    inputs = {}
    for topic in ruleset.topics:
        if not types.get(topic):
            raise IpyrosError(f"export: the rules of the guard of {guard.resolved} read {topic}, and nothing publishes "
                              "it now, so its type is not known: start what publishes it, then export again")
        inputs[topic] = name_of(types[topic])
    parts = []
    for number, (given, condition) in enumerate(zip(rules, ruleset.conditions), 1):
        here = f"{where}: rule {number}"
        paths = [(p.topic, p.plain_steps(), any(isinstance(s, msgpath.Slice) for s in p.steps), p.text)
                 for p in condition.inputs]
        only = condition_source(given.only, f"{here} only=", inputs=False) if given.only is not None else "None"
        fields = {"text": repr(given.condition), "paths": repr(paths), "when": condition_source(given.condition, here),
                  "command": repr(bool(condition.fields)), "stop": repr(given.stop), "scale": repr(given.scale),
                  "only": only, "only_text": repr(given.only), "limit": repr([tuple(b) for b in given.limit]),
                  "hold": repr(given.hold)}
        shown = {key: value for key, value in fields.items() if value not in _DEFAULTS.get(key, ())}
        parts.append("dict(" + ",\n             ".join(f"{key}={value}" for key, value in shown.items()) + ")")
    rules_text = "".join(f"\n        {part}," for part in parts)
    inputs_text = "{" + ", ".join(f"{topic!r}: {name}" for topic, name in inputs.items()) + "}"
    return (f"Rules([{rules_text}\n    ], stale={dict(ruleset.stale)!r}, inputs={inputs_text}, "
            f"floats={[tuple(p) for p in ruleset.floats or []]!r})")
