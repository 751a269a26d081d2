"""Message paths, as Foxglove and PlotJuggler users write them: ``/odom.pose.pose.position.x``.

A path is a topic, then the way into its messages::

    /odom.pose.pose.position.x                  a field of a field
    /scan.ranges[0]   /scan.ranges[-1]           an element (negative: from the end)
    /scan.ranges[10:20]   /poses.poses[:]        a slice: every element it holds
    /poses.poses[:]{position.x>0}.position.x     a filter: only the elements it is true for
    /tf.transforms[:]{child_frame_id=="base_link"}
    /cmd_vel{linear.x!=0}                        a filter on the message itself: only such messages
    /odom{pose.pose.position.x>$limit}           a variable, given by the caller

Filters compare a field path with ``==``, ``!=``, ``<``, ``<=``, ``>``, ``>=`` to a number, a quoted
string, ``true``/``false`` or a ``$variable``. :func:`parse` reads a path once (a one-line
:class:`MessagePathError` saying where it went wrong); :meth:`MessagePath.values` gives every value it
selects in one message (none when a filter leaves nothing). Pure: messages of either ROS, read by
their fields; no ROS library is imported.
"""

from __future__ import annotations

import operator
import re
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Optional, Union

from . import msgtypes
from .errors import IpyrosError
from .msgbuild import field_types, fields_of, nested_class

__all__ = ["Field", "Filter", "Index", "MessagePath", "MessagePathError", "Slice", "complete", "is_path", "parse",
           "split_topic"]


class MessagePathError(IpyrosError):
    """A message path that cannot be read, or names a field its messages do not have."""


@dataclass(frozen=True)
class Field:
    name: str


@dataclass(frozen=True)
class Index:
    index: int

    def __str__(self) -> str:
        return f"[{self.index}]"


@dataclass(frozen=True)
class Slice:
    start: Optional[int]
    stop: Optional[int]

    def __str__(self) -> str:
        return f"[{'' if self.start is None else self.start}:{'' if self.stop is None else self.stop}]"


@dataclass(frozen=True)
class Filter:
    path: tuple[str, ...]  # the field path inside the value filtered
    op: str
    value: Any  # a number, a string, a bool, or a variable's name (``variable`` True)
    variable: bool = False


Step = Union[Field, Index, Slice, Filter]

_OPS: dict[str, Callable[[Any, Any], bool]] = {"==": operator.eq, "!=": operator.ne, "<=": operator.le,
                                                ">=": operator.ge, "<": operator.lt, ">": operator.gt}
_NAME = re.compile(r"[A-Za-z_]\w*")
_PRIMITIVES = {"bool", "byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64",
               "float32", "float64", "string", "wstring"}
_NUMBERS = _PRIMITIVES - {"string", "wstring", "bool"}
_TOPIC = re.compile(r"/[A-Za-z0-9_/~]*")
_FILTER = re.compile(r"\s*([A-Za-z_][\w.]*)\s*(==|!=|<=|>=|<|>)\s*(.+?)\s*$")


@dataclass(frozen=True)
class MessagePath:
    """A parsed path: its topic and the steps into a message (see the module's docstring)."""

    text: str
    topic: str
    steps: tuple[Step, ...]

    @property
    def field(self) -> str:
        """The steps as written after the topic (``pose.pose.position.x``, ``ranges[0]``)."""
        return self.text[len(self.topic):].lstrip(".")

    def values(self, msg: Any, variables: Optional[Mapping[str, Any]] = None) -> list[Any]:
        """Every value the path selects in ``msg``, in order; ``[]`` if a filter leaves none."""
        found = [msg]
        for step in self.steps:
            found = [out for value in found for out in _apply(step, value, self, variables or {})]
        return found

    def plain_steps(self) -> tuple[tuple[Any, ...], ...]:
        """The steps as plain data, for code that walks them elsewhere (an exported node's): ``("field", name)``,
        ``("index", i)``, ``("slice", start, stop)``; a condition's path has no filter (one here: one line)."""
        out: list[tuple[Any, ...]] = []
        for step in self.steps:
            if isinstance(step, Filter):
                raise MessagePathError(f"{self.text}: a filter cannot be written as plain steps")
            out.append(("field", step.name) if isinstance(step, Field) else ("index", step.index)
                       if isinstance(step, Index) else ("slice", step.start, step.stop))
        return tuple(out)

    def check(self, cls: Any) -> None:
        """Say at once, in one line, if the path cannot select anything in messages of ``cls``: a field its
        type lacks (and which fields there are), an index into what is no array, a field of an array not
        indexed. What cannot be told from the type (a message not importable here) is left to the messages."""
        self._walk(cls)

    def check_number(self, cls: Any, doing: str = "a plot draws") -> None:
        """:meth:`check`, and then that the path ends on a number, one value each: a string, a bool, a message or a
        whole array is refused in one line. Types not known here are left to the messages."""
        at = self._walk(cls)
        if at is None:
            return
        what = f"an array of {at.kind}" if at.array else f"a {at.kind}" if at.cls is None else f"a {at.kind} message"
        if at.array or at.kind not in _NUMBERS:
            fix = "index it ([0]) or slice it ([:])" if at.array and at.kind in _NUMBERS else "name a number field"
            raise MessagePathError(f"{self.text}: {what}, not a number: {doing} numbers; {fix}")

    def _walk(self, cls: Any) -> Optional["_Typed"]:
        """Where the path ends in messages of ``cls``, checked on the way; None if a type on it is not known."""
        at = _Typed(self, cls, msgtypes.type_name(cls) or str(getattr(cls, "__name__", "message")))
        for step in self.steps:
            if isinstance(step, (Index, Slice)):
                if not at.array:
                    raise MessagePathError(f"{self.text}: {step} needs an array, and this is a {at.kind}")
                at = _Typed(self, at.cls, at.kind)  # each element, one value each
            elif isinstance(step, Filter):
                inner: Optional[_Typed] = at
                for name in step.path:  # read, not stepped into: the value filtered keeps its type
                    inner = inner.field(name) if inner is not None else None
                    if inner is None:
                        return None
            else:
                found = at.field(step.name)
                if found is None:
                    return None
                at = found
        return at


@dataclass(frozen=True)
class _Typed:
    """Where a path stands in a message's type, as :meth:`MessagePath.check` walks it."""

    path: MessagePath
    cls: Any  # the message class there; None for a primitive, or a message this Python cannot import
    kind: str  # its type name (an array's element type when ``array``)
    array: bool = False

    def field(self, name: str) -> Optional["_Typed"]:
        """The field ``name`` of this, or None when its type cannot be read here; one line if it is not there."""
        text = self.path.text
        if self.array:
            raise MessagePathError(f"{text}: {self.kind}[] is an array: index it or slice it ([0], [:]) before .{name}")
        if self.cls is None:
            if self.kind in _PRIMITIVES:
                raise MessagePathError(f"{text}: a {self.kind} has no field {name!r}")
            return None
        names, kinds = field_types(self.cls)
        if name not in names:
            raise MessagePathError(f"{text}: {self.kind} has no field {name!r} (it has {', '.join(names) or 'no fields'})")
        kind = kinds[names.index(name)]
        element = re.sub(r"\[\d*\]$", "", kind)
        return _Typed(self.path, None if element in _PRIMITIVES else nested_class(element), element, element != kind)


def is_path(text: str) -> bool:
    """Whether ``text`` goes on past a topic name into its messages (``/a.b``, ``/a[0]``, ``/a{x>0}``)."""
    return any(mark in text for mark in ".[{")


def split_topic(text: str) -> tuple[str, str]:
    """``/odom.pose.x`` → ``("/odom", ".pose.x")``: the topic, and the way into its messages."""
    at = min((text.index(mark) for mark in ".[{" if mark in text), default=len(text))
    return text[:at], text[at:]


_STEPS = re.compile(r"(?:\{[^{}]*\})*((?:\.[A-Za-z_]\w*(?:\[[^\[\]]*\]|\{[^{}]*\})*)*)\.([A-Za-z_]\w*)?")
_STEP = re.compile(r"\.([A-Za-z_]\w*)((?:\[[^\[\]]*\]|\{[^{}]*\})*)")


def complete(cls: Any, typed: str) -> list[tuple[str, str]]:
    """What TAB offers for the part of a path after its topic (``.pose.pose.po``): each field of the
    message there whose name starts with what is typed, as ``(typed with the field's name in place of
    its last word, the field's type)``. An index or a slice steps into an array's element type; a
    filter keeps the type. Nothing after a number or a string, a name the type lacks, an array not
    yet indexed, an unclosed ``[``/``{``, or no class (a type unknown here)."""
    found = _STEPS.fullmatch(typed) if cls is not None else None
    if found is None:
        return []
    steps, partial = found.group(1), found.group(2) or ""
    for name, after in _STEP.findall(steps):
        names, kinds = field_types(cls)
        if name not in names:
            return []
        kind = kinds[names.index(name)]
        if kind.endswith("]") and "[" not in after:
            return []  # a field of an array's element needs an index or a slice first
        inner = nested_class(re.sub(r"\[\d*\]$", "", kind))
        if inner is None:
            return []
        cls = inner
    head = typed[:len(typed) - len(partial)]
    return [(head + name, kind) for name, kind in zip(*field_types(cls)) if name.startswith(partial)]


def parse(text: str) -> MessagePath:
    """Read a message path; a one-line :class:`MessagePathError` saying where it went wrong."""
    text = text.strip()
    topic = _TOPIC.match(text)
    if topic is None or topic.group(0) in ("", "/"):
        raise MessagePathError(f"{text!r}: a message path starts with a topic, e.g. /odom.pose.pose.position.x")
    rest, steps = text[topic.end():], list[Step]()
    position = topic.end()
    while rest:
        if rest[0] == ".":
            name = _NAME.match(rest, 1)
            if name is None:
                raise _error(text, position, "a field name after '.'")
            steps.append(Field(name.group(0)))
            taken = name.end()
        elif rest[0] == "[":
            close = rest.find("]")
            if close < 0:
                raise _error(text, position, "a closing ']'")
            steps.append(_bracket(rest[1:close], text, position))
            taken = close + 1
        elif rest[0] == "{":
            close = rest.find("}")
            if close < 0:
                raise _error(text, position, "a closing '}'")
            steps.append(_filter(rest[1:close], text, position))
            taken = close + 1
        else:
            raise _error(text, position, "'.field', '[index]', '[start:stop]' or '{filter}'")
        rest, position = rest[taken:], position + taken
    return MessagePath(text, topic.group(0).rstrip("/") or "/", tuple(steps))


def _error(text: str, position: int, wanted: str) -> MessagePathError:
    return MessagePathError(f"{text!r}: at {text[position:position + 20]!r} (character {position + 1}): "
                            f"expected {wanted}")


def _bracket(inside: str, text: str, position: int) -> Step:
    try:
        if ":" in inside:
            start, _, stop = inside.partition(":")
            return Slice(int(start) if start.strip() else None, int(stop) if stop.strip() else None)
        return Index(int(inside))
    except ValueError:
        raise _error(text, position, "an index ([2], [-1]) or a slice ([1:3], [:])") from None


def _filter(inside: str, text: str, position: int) -> Filter:
    found = _FILTER.match(inside)
    if found is None:
        raise _error(text, position, "a filter such as {position.x>0} or {child_frame_id==\"base_link\"}")
    path, op, word = found.groups()
    if word.startswith("$") and _NAME.fullmatch(word[1:]):
        return Filter(tuple(path.split(".")), op, word[1:], variable=True)
    if len(word) >= 2 and word[0] == word[-1] and word[0] in "'\"":
        return Filter(tuple(path.split(".")), op, word[1:-1])
    if word in ("true", "false"):
        return Filter(tuple(path.split(".")), op, word == "true")
    try:
        return Filter(tuple(path.split(".")), op, int(word) if re.fullmatch(r"-?\d+", word) else float(word))
    except ValueError:
        raise _error(text, position, "a number, a quoted string, true, false or a $variable after "
                                     f"{op!r}") from None


def _field(value: Any, name: str, path: MessagePath) -> Any:
    have = fields_of(value) if not isinstance(value, (list, tuple, str, bytes)) else []
    if name not in have:
        kind = msgtypes.type_name(value) or type(value).__name__
        listed = ", ".join(have) if have else "no fields"
        raise MessagePathError(f"{path.text}: {kind} has no field {name!r} (it has {listed})")
    return getattr(value, name)


def _sequence(value: Any, path: MessagePath, step: Step) -> Any:
    # a uint8[] or char[] is bytes on ROS 1 (genpy), a list or an array on ROS 2: indexed alike, to ints
    if isinstance(value, str) or not hasattr(value, "__getitem__") or not hasattr(value, "__len__"):
        kind = msgtypes.type_name(value) or type(value).__name__
        raise MessagePathError(f"{path.text}: {step} needs an array, and this is a {kind}")
    return value


def _apply(step: Step, value: Any, path: MessagePath, variables: Mapping[str, Any]) -> list[Any]:
    if isinstance(step, Field):
        return [_field(value, step.name, path)]
    if isinstance(step, Index):
        items = _sequence(value, path, step)
        return [items[step.index]] if -len(items) <= step.index < len(items) else []
    if isinstance(step, Slice):
        return list(_sequence(value, path, step)[step.start:step.stop])
    inner = value
    for name in step.path:
        inner = _field(inner, name, path)
    if step.variable:
        if step.value not in variables:
            raise MessagePathError(f"{path.text}: no variable ${step.value}; give it (variables={{{step.value!r}: ...}})")
        wanted = variables[step.value]
    else:
        wanted = step.value
    if isinstance(inner, bytes):
        inner = inner.decode(errors="replace")
    try:
        return [value] if _OPS[step.op](inner, wanted) else []
    except TypeError:
        raise MessagePathError(f"{path.text}: cannot compare {'.'.join(step.path)} ({type(inner).__name__}) "
                               f"with {wanted!r}") from None
