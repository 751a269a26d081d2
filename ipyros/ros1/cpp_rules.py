"""A guard's rules compiled into the C++ of a ROS 1 export (``nd.export(DIR, language="cpp")``).

The session judges rules with :class:`ipyros.core.rules.RuleSet`; the exported roscpp node judges them with C++
written here from the same parse (:func:`ipyros.core.rules.parse_condition`), with the same promises (see
:mod:`ipyros.core.rules`): an input never heard, older than its ``stale`` time, or a rule that cannot be told (a NaN
compared, an index past the end, a division by zero, a minimum of nothing) is the stop message; of the rules in
force, any stop, then any ``only`` the command breaks, then the smallest ``scale``, then the limits' intersection; a
rule stays in force ``hold`` s; judged on each command and, with none coming, every 10 ms and as each input comes.

C++ is typed where a condition is not: each value's kind (a number, a true/false, an array of numbers) is known here
from the genpy classes of the inputs' types and the guarded type, so a condition that would always be a stop in the
session (a number where a true/false is wanted, an array compared) is refused at export in one line, as is what this
compiler does not write (a string field, a ``uint8[]`` read as bytes, an index after a slice).
"""

from __future__ import annotations

import ast
import re
from typing import Any, Mapping, Optional

from ..core import msgpath
from ..core.errors import IpyrosError
from ..core.model import GuardModel
from ..core.rules import RuleSet, as_rule, input_index, parse_condition
from .cpp_text import cpp_type, indent, message_class, string, visit

__all__ = ["RULES_HELPERS", "CppRules"]

_NUMBERS = {"float32", "float64", "int8", "int16", "int32", "int64", "uint8", "uint16", "uint32", "uint64", "byte",
            "char"}
_COMPARE = {ast.Eq: "==", ast.NotEq: "!=", ast.Lt: "<", ast.LtE: "<=", ast.Gt: ">", ast.GtE: ">="}
_ARITHMETIC = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*"}

#: What every guard with rules uses, written once in the source.
RULES_HELPERS = r'''
// A guard's rules: what cannot be told on what was heard (a NaN, an index past the end, a division by zero, the
// minimum of nothing) throws, and the guard sends the stop message.
struct RuleError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

inline double num(double v) {
  if (std::isnan(v)) throw RuleError("a NaN");
  return v;
}

inline double quot(double a, double b) {
  if (b == 0) throw RuleError("a division by zero");
  return a / b;
}

template <class T>
const T& need(const T* c, const char* text) {
  if (c == nullptr) throw RuleError(std::string(text) + ": no command to read it from");
  return *c;
}

template <class A>
auto at(const A& a, long i, const char* text) -> decltype(a[0]) {
  long n = static_cast<long>(a.size());
  if (i < -n || i >= n) throw RuleError(std::string(text) + ": nothing in the last message");
  return a[i < 0 ? i + n : i];
}

template <class A, class F>
std::vector<double> sliced(const A& a, bool has_start, long start, bool has_stop, long stop, F value) {
  long n = static_cast<long>(a.size());
  long first = !has_start ? 0 : start < 0 ? std::max(start + n, 0L) : std::min(start, n);
  long end = !has_stop ? n : stop < 0 ? std::max(stop + n, 0L) : std::min(stop, n);
  std::vector<double> out;
  for (long i = first; i < end; ++i) out.push_back(value(a[i]));
  return out;
}

template <class A>
double extreme(const A& values, bool least, const char* name) {  // a NaN (a laser's invalid ray) is left out
  bool any = false;
  double best = 0;
  for (const auto& e : values) {
    double v = static_cast<double>(e);
    if (std::isnan(v)) continue;
    if (!any || (least ? v < best : v > best)) best = v;
    any = true;
  }
  if (!any) throw RuleError(std::string(name) + " of no value (nothing but NaN, or empty)");
  return best;
}

inline std::string seconds(double s) {
  char text[32];
  std::snprintf(text, sizeof text, "%.2f", s);
  return text;
}
'''


class CppRules:
    """The C++ of one guard's rules: its members, what its constructor subscribes, and its methods ``armed``,
    ``judge``, ``pass`` (a command through its rules, then its limits) and ``look`` (with no command coming). Each
    input's type is the live graph's at export (``topic_types``); one line if it has none, or for what C++ here
    cannot express."""

    def __init__(self, guard: GuardModel, topic_types: Mapping[str, str]) -> None:
        self.guard = guard
        self.where = f"export(language='cpp'): the guard of {guard.resolved}"
        self.rules = [as_rule(given, self.where) for given in guard.rules]
        self.cls, self.cpp = message_class(guard.type), cpp_type(guard.type)
        topics = RuleSet(self.rules, None, guard.resolved, guard.stale, self.where).topics
        missing = [t for t in topics if not topic_types.get(t)]
        if missing:
            raise IpyrosError(f"{self.where}: its rules read {missing[0]}, and nothing publishes it now, so its type "
                              "is not known: start what publishes it, then export again")
        self.inputs = {topic: topic_types[topic] for topic in topics}
        self.input_classes = {topic: message_class(kind) for topic, kind in self.inputs.items()}
        self.ruleset = RuleSet(self.rules, self.cls, guard.resolved, guard.stale, self.where, self.input_classes)

    @property
    def types(self) -> set[str]:
        """The message types the rules' inputs are (their headers)."""
        return set(self.inputs.values())

    def members(self) -> str:
        lines = ["// its rules' inputs: the last message of each and when it came (steady seconds)"]
        for number, (topic, kind) in enumerate(self.inputs.items()):
            lines.append(f"{cpp_type(kind)}::ConstPtr in{number}_;  // {topic}")
            lines.append(f"double in{number}_at_ = 0;")
            lines.append(f"ros::Subscriber in{number}_sub_;")
        lines += [f"double hold_until_[{max(len(self.rules), 1)}];  // each rule in force until then (its hold)",
                  f"{self.cpp} last_cmd_;  // the last command that passed", "bool has_last_ = false;",
                  "double armed_at_ = 0;", "std::string ruling_;  // why its rules hold the stop message now"]
        return "\n".join(lines)

    def setup(self) -> str:
        lines = ["armed_at_ = ros::SteadyTime::now().toSec() + 1.0;  // its inputs' first messages awaited 1 s at most",
                 f"std::fill(hold_until_, hold_until_ + {len(self.rules)}, -INFINITY);"]
        for number, (topic, kind) in enumerate(self.inputs.items()):
            lines.append(f"in{number}_sub_ = nh.subscribe<{cpp_type(kind)}>({string(topic)}, 1, [this](const "
                         f"{cpp_type(kind)}::ConstPtr& msg) {{ std::lock_guard<std::mutex> lock(mutex_); "
                         f"double now = ros::SteadyTime::now().toSec(); in{number}_ = msg; in{number}_at_ = now; "
                         "look(now); }, ros::VoidConstPtr(), noDelay());")
        return "\n".join(lines)

    def methods(self) -> str:
        heard = " && ".join(f"in{n}_" for n in range(len(self.inputs))) or "true"
        return _METHODS.format(cpp=self.cpp, heard=heard, judge=indent(self._judge(), 2),
                               topic=string(self.guard.resolved))

    # -- judge --------------------------------------------------------------------------------------
    def _judge(self) -> str:
        lines = []
        for number, topic in enumerate(self.inputs):
            lines.append(f"if (!in{number}_) return {string(f'{topic} not heard yet')};")
            most = self.ruleset.stale.get(topic)
            if most is not None:
                lines.append(f"if (now - in{number}_at_ > {most!r}) return std::string({string(topic + ' stale (')}) "
                             f"+ seconds(now - in{number}_at_) + {string(f' s old, at most {most:g} s)')};")
        limited = list(dict.fromkeys(path for r in self.rules for path, _, _ in r.limit))
        lines += ["double scale = 1.0;", *(f"double low{k} = -INFINITY, high{k} = INFINITY;  // {path}"
                                           for k, path in enumerate(limited))]
        lines += [f"bool only{n} = false;" for n, r in enumerate(self.rules, 1) if r.only is not None]
        for number, (given, condition) in enumerate(zip(self.rules, self.ruleset.conditions), 1):
            here = f"{self.where}: rule {number}"
            when = self._condition(given.condition, here, condition.inputs)
            act = [f"return {string(f'rule {number}: {given.condition}')};"] if given.stop else \
                [f"scale = std::min(scale, {given.scale!r});"] if given.scale is not None else \
                [f"only{number} = true;"] if given.only is not None else \
                [line for path, low, high in given.limit for k in [limited.index(path)]
                 for line in (f"low{k} = std::max(low{k}, {low!r});", f"high{k} = std::min(high{k}, {high!r});")]
            guard = "if (c != nullptr) " if condition.fields else ""
            lines += [f"// rule {number}: {given}", guard + "{", "  bool holds;",
                      f"  try {{ holds = {when}; }} catch (const RuleError& e) {{ return std::string("
                      f"{string(f'rule {number} could not be told (')}) + e.what() + \")\"; }}",
                      f"  if (holds) hold_until_[{number - 1}] = now + {given.hold!r};",
                      f"  if (holds || now < hold_until_[{number - 1}]) {{", *(f"    {line}" for line in act), "  }",
                      "}"]
        lines.append("if (c == nullptr) return \"\";")
        for number, given in enumerate(self.rules, 1):
            if given.only is not None:
                only = self._condition(given.only, f"{self.where}: rule {number} only=", ())
                said = f"rule {number}: only {given.only}"
                lines += [f"if (only{number}) {{", "  bool ok;",
                          f"  try {{ ok = {only}; }} catch (const RuleError& e) {{ return std::string("
                          f"{string(said + ' could not be told (')}) + e.what() + \")\"; }}",
                          f"  if (!ok) return {string(said)};", "}"]
        floats = self.ruleset.floats or []
        if floats:
            lines += ["if (scale != 1.0) {", *(f"  c->{'.'.join(path)} *= scale;" for path in floats),
                      "  *changed = true;", "}"]
        for k, path in enumerate(limited):
            if "[-" in path:
                raise IpyrosError(f"{self.where}: a rule's limit on {path!r}: the C++ export clamps an index from "
                                  "the start only; give it so, or export in Python (language='python')")
            lines.append(f"if (low{k} > high{k}) return {string(f'the rules in force leave {path} no value')};")
            lines.append(visit(self.cls, path, "(*c)", lambda place, v, k=k: (
                f"if ({v} < low{k} || {v} > high{k}) {{ {v} = std::min(std::max(double({v}), low{k}), high{k}); "
                "*changed = true; }")))
        lines.append("return \"\";")
        return "\n".join(lines)

    def _condition(self, text: str, where: str, paths: tuple[msgpath.MessagePath, ...]) -> str:
        top, _ = parse_condition(text, where, inputs=bool(paths))
        code, kind = _Compiler(self, text, where, paths).render(top)
        if kind != "bool":
            raise _Compiler(self, text, where, paths).refuse(top, f"gives {_KINDS[kind]}, not a true/false")
        return code


_KINDS = {"num": "a number", "bool": "a true/false", "array": "an array"}


class _Compiler:
    """A condition's tree as a C++ expression of a known kind (``num``, ``bool``, ``array``), evaluated as
    :class:`ipyros.core.rules.Condition` evaluates it: in the same order, a :data:`RULES_HELPERS` ``RuleError`` where
    the session's raises."""

    def __init__(self, rules: CppRules, text: str, where: str, paths: tuple[msgpath.MessagePath, ...]) -> None:
        self.rules, self.text, self.where, self.paths = rules, text, where, paths

    def refuse(self, node: Optional[ast.AST], what: str) -> IpyrosError:
        spelled = re.sub(r"\b_p(\d+)_*", lambda m: self.paths[int(m[1])].text, ast.unparse(node)) if node else ""
        part = f"{spelled!r} " if spelled else ""
        return IpyrosError(f"{self.where}: {self.text!r}: {part}{what}: the C++ export cannot write it; export in "
                           "Python (language='python'), which judges it as the session does")

    def render(self, node: ast.AST) -> tuple[str, str]:  # noqa: C901 - one case a kind of node, as rules._Compiler
        if isinstance(node, ast.Constant):
            return ("true" if node.value else "false", "bool") if isinstance(node.value, bool) else \
                (repr(float(node.value)), "num")
        index = input_index(node.id) if isinstance(node, ast.Name) else None
        if index is not None:
            path = self.paths[index]
            number = list(self.rules.inputs).index(path.topic)
            return self.walk(f"(*in{number}_)", self.rules.input_classes[path.topic], path.plain_steps(), path.text)
        if isinstance(node, (ast.Name, ast.Attribute, ast.Subscript)):
            return self.command_field(node)
        if isinstance(node, ast.BoolOp):
            parts = [self.want(value, "bool") for value in node.values]
            return "(" + (" && " if isinstance(node.op, ast.And) else " || ").join(parts) + ")", "bool"
        if isinstance(node, ast.UnaryOp):
            if isinstance(node.op, ast.Not):
                return f"(!{self.want(node.operand, 'bool')})", "bool"
            operand = self.want(node.operand, "num")
            return (f"(-num({operand}))" if isinstance(node.op, ast.USub) else f"num({operand})"), "num"
        if isinstance(node, ast.BinOp):
            left, right = self.want(node.left, "num"), self.want(node.right, "num")
            if isinstance(node.op, ast.Div):
                return f"quot(num({left}), num({right}))", "num"
            return f"(num({left}) {_ARITHMETIC[type(node.op)]} num({right}))", "num"
        if isinstance(node, ast.Compare):
            return self.compare(node), "bool"
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
            return self.call(node.func.id, node)
        raise self.refuse(node, "is not a condition")

    def want(self, node: ast.AST, kind: str) -> str:
        code, found = self.render(node)
        if found != kind:
            raise self.refuse(node, f"is {_KINDS[found]} where {_KINDS[kind]} is wanted (always a stop)")
        return code

    def compare(self, node: ast.Compare) -> str:
        """A chain (``0.1 < x < 0.5``) as a lambda: each term when reached, a NaN compared a RuleError."""
        terms = [self.render(term) for term in [node.left, *node.comparators]]
        kinds = {kind for _, kind in terms}
        if kinds == {"bool"} and all(type(op) in (ast.Eq, ast.NotEq) for op in node.ops):
            kind = "bool"
        elif kinds == {"num"}:
            kind = "double"
        else:
            raise self.refuse(node, "compares " + " with ".join(_KINDS[k] for _, k in terms))
        body = [f"{kind} t0 = {terms[0][0]};"]
        for n, (op, (code, _)) in enumerate(zip(node.ops, terms[1:]), 1):
            body.append(f"{kind} t{n} = {code};")
            if kind == "double":
                body.append(f"if (std::isnan(t{n - 1}) || std::isnan(t{n})) throw RuleError(\"a NaN compared\");")
            body.append(f"if (!(t{n - 1} {_COMPARE[type(op)]} t{n})) return false;")
        return "[&]() { " + " ".join(body) + " return true; }()"

    def call(self, name: str, node: ast.Call) -> tuple[str, str]:
        args = [self.render(arg) for arg in node.args]
        if name in ("min", "max"):
            if len(args) == 1 and args[0][1] == "array":
                values = args[0][0]
            elif all(kind == "num" for _, kind in args):
                values = "std::vector<double>{" + ", ".join(code for code, _ in args) + "}"
            else:
                raise self.refuse(node, f"{name} takes one array or numbers")
            return f"extreme({values}, {'true' if name == 'min' else 'false'}, {string(name)})", "num"
        if len(args) != 1:
            raise self.refuse(node, f"{name} takes one value")
        if name == "len" and args[0][1] == "array":
            return f"double(({args[0][0]}).size())", "num"
        if name == "abs" and args[0][1] == "num":
            return f"std::fabs(num({args[0][0]}))", "num"
        raise self.refuse(node, f"{name} of {_KINDS[args[0][1]]}")

    def command_field(self, node: ast.AST) -> tuple[str, str]:
        steps: list[tuple[Any, ...]] = []
        at = node
        while not isinstance(at, ast.Name):
            if isinstance(at, ast.Attribute):
                steps.append(("field", at.attr))
                at = at.value
            else:
                assert isinstance(at, ast.Subscript) and isinstance(at.slice, ast.Constant)
                steps.append(("index", at.slice.value))
                at = at.value
        steps.append(("field", at.id))
        text = ast.unparse(node)
        return self.walk(f"need(c, {string(text)})", self.rules.cls, tuple(reversed(steps)), text)

    def walk(self, root: str, cls: Any, steps: tuple[tuple[Any, ...], ...], text: str) -> tuple[str, str]:
        """The C++ of the value ``steps`` reach from ``root`` (a message of genpy class ``cls``), and its kind."""
        expr, kind, inside = root, ("msg", cls), None  # inside: (the array, its slice) once a slice is passed
        for step in steps:
            if step[0] == "field":
                if kind[0] != "msg":
                    raise self.refuse(None, f"{text}: {step[1]} of a value with no fields")
                slots = dict(zip(kind[1].__slots__, kind[1]._slot_types))
                if step[1] not in slots:
                    raise self.refuse(None, f"{text}: {kind[1]._type} has no field {step[1]!r}")
                expr, kind = f"{expr}.{step[1]}", _kind(slots[step[1]])
            elif kind[0] != "array":
                raise self.refuse(None, f"{text}: {step} of a value that is not an array")
            elif inside is not None:
                raise self.refuse(None, f"{text}: an index or a slice after a slice")
            elif step[0] == "index":
                expr, kind = f"at({expr}, {step[1]}, {string(text)})", _kind(kind[1])
            else:
                inside, expr, kind = (expr, step[1:]), "e", _kind(kind[1])
        if kind == ("array", "uint8") or kind == ("array", "char") or kind[0] == "other":
            raise self.refuse(None, f"{text}: a {kind[1]}")
        if inside is None and kind[0] == "num":
            return f"double({expr})", "num"
        if inside is None and kind[0] == "bool":
            return f"bool({expr})", "bool"
        if inside is None and kind[0] == "array" and kind[1] in _NUMBERS:
            return expr, "array"
        if inside is None:
            raise self.refuse(None, f"{text}: a {kind[1] if kind[0] != 'msg' else 'message'}")
        if kind[0] != "num":
            raise self.refuse(None, f"{text}: a slice of what is not a number")
        (array, (start, stop)) = inside
        bounds = f"{'false' if start is None else 'true'}, {start or 0}, {'false' if stop is None else 'true'}, " \
                 f"{stop or 0}"
        return f"sliced({array}, {bounds}, [&](const auto& e) {{ return double({expr}); }})", "array"


def _kind(slot_type: str) -> tuple[str, Any]:
    """What a field of ``slot_type`` is to a condition: a number, a true/false, an array (of its element's type), a
    message (its class), or other (a string, a time)."""
    if "[" in slot_type:
        return "array", slot_type.partition("[")[0]
    if slot_type in _NUMBERS:
        return "num", slot_type
    if slot_type == "bool":
        return "bool", slot_type
    if "/" in slot_type or slot_type == "Header":
        return "msg", message_class("std_msgs/Header" if slot_type == "Header" else slot_type)
    return "other", slot_type


_METHODS = """\
// Whether its rules judge yet: once each input was heard, or a second after start (then one never heard is a stop).
bool armed(double now) {{ return now >= armed_at_ || ({heard}); }}

// Why the stop message goes out in place of *c (nullptr: no command), "" if not; *c scaled and clamped by the
// rules in force (*changed then says so).
std::string judge({cpp}* c, double now, bool* changed) {{
{judge}
}}

// judge(), and what it could not judge for another reason than a rule's (a RuleError): the stop message too.
std::string judged({cpp}* c, double now, bool* changed) {{
  try {{
    return judge(c, now, changed);
  }} catch (const std::exception& e) {{
    return std::string("its rules could not be judged (") + e.what() + ")";
  }}
}}

// A command through its rules (the stop message in its place when they say so), then its limits and rate limits.
bool pass({cpp}& m) {{
  double now = ros::SteadyTime::now().toSec();
  if (!armed(now)) return false;  // its inputs not heard yet, at start: nothing judged, nothing sent
  bool changed = false;
  if (!judged(&m, now, &changed).empty()) {{
    m = stop_;
    return true;
  }}
  if (!check(m)) return false;
  last_cmd_ = m;
  has_last_ = true;
  return true;
}}

// Its rules judged with no command coming (every 10 ms, and as each input comes): while they hold the stop message
// (an input stale, a stop rule, a last command they would now change) it goes out at the guard's rate; said once.
void look(double now) {{
  if (!armed(now)) return;
  std::string why;
  if (has_last_) {{
    {cpp} copy = last_cmd_;
    bool changed = false;
    why = judged(&copy, now, &changed);
    if (why.empty() && changed) why = "the last command would now be changed";
  }} else {{
    why = judged(nullptr, now, nullptr);
  }}
  ros::SteadyTime at = ros::SteadyTime::now();
  if (!why.empty() && (at - stopped_).toSec() >= period_) {{
    pub_.publish(stop_);
    stopped_ = at;
    last_.clear();  // a rate-limited field starts again from the stop message
    last_cmd_ = stop_;  // the last command now: within the rules (checked when the guard was declared)
  }}
  if (!why.empty() && ruling_.empty()) {{
    ROS_WARN("guard %s: %s: the stop message goes out until its rules let a command pass", {topic}, why.c_str());
  }} else if (why.empty() && !ruling_.empty() && ruling_.rfind("the last command", 0) != 0) {{
    ROS_INFO("guard %s: its rules let commands pass again", {topic});
  }}
  ruling_ = why;
}}"""
