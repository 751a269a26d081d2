"""A message type as a form to fill in: one field a control, with a sensible range, pure (no widget library).

``%pub --widget /cmd_vel geometry_msgs/Twist`` draws, in Jupyter, a slider for each number of
the message (``linear.x``, ...), a toggle for each bool and a text box for each string;
:func:`form_fields` says which controls, from the type alone (nested messages flattened into
dotted paths), and :func:`message_from` builds the message back from their values. Arrays and
times are left out of the form (said in one line by :func:`form_fields`'s second result): a
slider per element of an array of unknown length means nothing.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any, Optional

from .msgbuild import build_message, field_types, nested_class

__all__ = ["FormField", "form_fields", "message_from", "param_field"]

_FLOATS = {"float32", "float64"}
_UNSIGNED_BYTES = {"uint8", "byte", "char"}
_INTS = {"int8", "int16", "int32", "int64", "uint16", "uint32", "uint64", *_UNSIGNED_BYTES}
_TIMES = {"time", "duration", "builtin_interfaces/Time", "builtin_interfaces/Duration"}

#: The range a float slider starts with: wide enough for a command, a pose, a gain; it widens for the value it holds.
FLOAT_RANGE = 10.0
#: The range an integer slider starts with (unsigned: from 0), within what its type can hold.
INT_RANGE = 100


@dataclass(frozen=True)
class FormField:
    """One control of a form: the field's dotted path, what it holds and where a slider for it goes."""

    path: str
    kind: str  # "float", "int", "bool" or "text"
    value: Any
    low: float = 0.0
    high: float = 0.0
    step: float = 0.0


def form_fields(cls: type, msg: Optional[Any] = None,
                bounds: Optional[dict[str, tuple[float, float]]] = None) -> tuple[list[FormField], list[str]]:
    """The controls of a form for messages of ``cls`` (at the values of ``msg``, else the type's defaults), and the
    paths left out of it (arrays, times). ``bounds`` ({dotted path: (low, high)}, a guard's limits) are the ranges
    of those numbers' sliders, their values brought within them: a slider then shows only what passes the guard."""
    fields: list[FormField] = []
    left_out: list[str] = []
    _walk(cls, msg if msg is not None else cls(), "", fields, left_out, bounds or {})
    return fields, left_out


def _walk(cls: type, msg: Any, prefix: str, fields: list[FormField], left_out: list[str],
          bounds: dict[str, tuple[float, float]]) -> None:
    names, kinds = field_types(cls)
    for name, kind in zip(names, kinds):
        path, value = f"{prefix}{name}", getattr(msg, name)
        bound = bounds.get(path)
        if kind.endswith("]") or kind in _TIMES:
            left_out.append(path)
        elif kind in _FLOATS:
            if bound is not None:
                low, high = float(bound[0]), float(bound[1])
            else:
                low, high = -max(FLOAT_RANGE, 2 * abs(float(value))), max(FLOAT_RANGE, 2 * abs(float(value)))
            fields.append(FormField(path, "float", min(max(float(value), low), high), low, high, (high - low) / 2000))
        elif kind in _INTS:
            if bound is not None:  # the whole numbers within the guard's limits
                low, high = math.ceil(bound[0]), math.floor(bound[1])
            else:
                low = 0 if kind.startswith("u") or kind in _UNSIGNED_BYTES else -INT_RANGE
                high = 255 if kind in _UNSIGNED_BYTES else INT_RANGE
                low, high = min(low, int(value)), max(high, int(value))
            fields.append(FormField(path, "int", min(max(int(value), low), high), low, high, 1))
        elif kind == "bool":
            fields.append(FormField(path, "bool", bool(value)))
        elif kind in ("string", "wstring"):
            fields.append(FormField(path, "text", str(value)))
        else:
            inner = nested_class("std_msgs/Header" if kind == "Header" else kind)
            if inner is None:
                left_out.append(path)
            else:
                _walk(inner, value, f"{path}.", fields, left_out, bounds)


def message_from(cls: type, values: dict[str, Any]) -> Any:
    """A message of ``cls`` with each dotted path of ``values`` set, checked field by field as ``%pub`` checks it."""
    nested: dict[str, Any] = {}
    for path, value in values.items():
        *parents, last = path.split(".")
        place = nested
        for part in parents:
            place = place.setdefault(part, {})
        place[last] = value
    return build_message(cls, nested)


def param_field(name: str, value: Any, described: dict[str, Any]) -> Optional[FormField]:
    """The control of a parameter (``%params --widget``), its range from what its node says of it (``min``/``max``:
    a dynamic_reconfigure server's, or a ROS 2 descriptor's range), else one around its value; None for a value no
    control holds (a list, bytes)."""
    low: Any = described.get("min")
    high: Any = described.get("max")
    step: Any = described.get("step")
    span = re.fullmatch(r"\s*(\S+) to (\S+?)(?: by (\S+))?\s*", str(described.get("range", "")))
    if span:  # a ROS 2 descriptor's, as %param --describe says it: "0.0 to 2.0 by 0.1"
        low, high, step = float(span[1]), float(span[2]), float(span[3]) if span[3] else None
    if isinstance(value, bool):
        return FormField(name, "bool", value)
    if isinstance(value, int):
        if low is None or high is None:
            reach = max(INT_RANGE, 2 * abs(value))
            low, high = (0 if value >= 0 else -reach), reach
        return FormField(name, "int", value, int(low), int(high), int(step or 1))
    if isinstance(value, float):
        if low is None or high is None:
            spread = max(FLOAT_RANGE, 2 * abs(value))
            low, high = -spread, spread
        return FormField(name, "float", value, float(low), float(high),
                         float(step or (float(high) - float(low)) / 1000))
    if isinstance(value, str):
        return FormField(name, "text", value)
    return None
