"""Build a ROS message from plain data (a dict, a list, YAML text), checking every field.

``rostopic pub`` fills a message from YAML and quietly turns mistakes into defaults or
odd values; at a prompt that costs a debugging session. Here every value is checked
against the field's declared type, and the first problem is an error that names the
field by its path (``twist.linear.q``) and says what was expected:

    build_message("geometry_msgs/Twist", {"linear": {"x": 0.5}})   # the other fields: defaults
    build_message("std_msgs/String", "hello")                     # a one-field message
    build_message("geometry_msgs/Vector3", [1, 2, 3])             # every field, in order
    build_message("geometry_msgs/Twist", {"linear": {"q": 1}})
    # MessageTypeError: geometry_msgs/Twist: linear.q: no such field (geometry_msgs/Vector3 has x, y, z)

Omitted fields keep the message's defaults (zero, empty), as in ROS. Pure functions:
no ROS node, no network.
"""

from __future__ import annotations

import copy

import functools
import math
import re
import time
from typing import Any

import yaml

from . import msgtypes
from .errors import DataError, MessageTypeError
from .userdata import literal_or_yaml

# ROS 1 integer types and their ranges; byte is ROS 1's (deprecated) int8, char its uint8.
_INT_BITS = {"int8": 8, "int16": 16, "int32": 32, "int64": 64, "byte": 8}
_UINT_BITS = {"uint8": 8, "uint16": 16, "uint32": 32, "uint64": 64, "char": 8}
_FLOATS = {"float32", "float64"}
#: The largest finite float32: past it the wire would carry an infinity (rclpy) or the send fails (genpy).
FLOAT32_MAX = 3.4028234663852886e38
_ARRAY = re.compile(r"^(?P<base>[^\[\]]+)\[(?P<size>\d*)\]$")
_PRIMITIVE_TYPES = {*_INT_BITS, *_UINT_BITS, *_FLOATS, "bool", "string", "wstring"}


def parse_data(text: str) -> Any:
    """Read the data part of a ``%pub`` line: a Python literal, else YAML; empty gives None.

    A Python literal first, so ``{'data': 'x'}``, ``True`` and ``None`` mean what they mean
    in Python; YAML otherwise (``{linear: {x: 1}}``, ``data: hi`` or a multi-line block).
    Read with limits (:mod:`ipyros.core.userdata`): an alias bomb is refused in one line.
    """
    try:
        return literal_or_yaml(text, "the message data")
    except DataError as error:
        raise MessageTypeError(f"{error}; give a dict like {{'data': 'hi'}} or YAML like 'data: hi'") from None


def build_message(msg_type: Any, data: Any = None, *, nonfinite: bool = False) -> Any:
    """A message of ``msg_type`` (class or ``"pkg/Type"``) filled from ``data``.

    ``data`` is None (all defaults), a dict of fields (nested dicts for nested messages),
    a list of every field's value in declaration order, a single value for a message with
    one field, or already a message of that type. NaN and infinities are refused unless
    ``nonfinite``: typed by mistake they would reach a controller as a command.
    """
    type_name, cls = msgtypes.resolve_message(msg_type)
    try:
        return _Builder(nonfinite).message(cls, data, "")
    except _FieldError as error:
        raise MessageTypeError(f"{type_name}: {error}") from None


def template(msg_type: Any) -> str:
    """A message of ``msg_type`` with every field at its default, as one line of YAML.

    What TAB after ``%pub TOPIC TYPE`` inserts: nested, every field named, ready to edit
    and send (``%pub`` reads it back as it is).
    """
    _, cls = msgtypes.resolve_message(msg_type)
    return yaml.safe_dump(_as_data(cls()), default_flow_style=True, width=1 << 20, sort_keys=False).strip()


def definition(type_name: str, expand: bool = False) -> str:
    """A message, service or action type's definition, as ``rosmsg show`` / ``ros2 interface show`` print it:
    a line per constant and field (``float64 x``); ``---`` between a service's request and response and an
    action's goal, result and feedback; nested message types spelled out below their field when ``expand``.
    Types in ROS 1's spelling on both ROS, as the model writes them."""
    try:
        parts = [msgtypes.resolve_message(type_name)[1]]
    except MessageTypeError as not_message:
        try:
            cls: Any = msgtypes.resolve_service(type_name)[1]
            parts = [cls._request_class, cls._response_class] if hasattr(cls, "_request_class") else \
                [cls.Request, cls.Response]
        except MessageTypeError:
            try:
                parts = list(msgtypes.action_messages(msgtypes.resolve_action(type_name)[1]))
            except MessageTypeError:
                raise not_message from None
    return "\n---\n".join("\n".join(_definition_lines(part, expand, "")) for part in parts)


def _definition_lines(cls: type, expand: bool, indent: str) -> list[str]:
    lines = [f"{indent}{name}={value!r}" for name, value in _constants(cls)]
    for name, field_type in zip(*field_types(cls)):
        lines.append(f"{indent}{field_type} {name}")
        nested = nested_class(field_type.split("[")[0]) if expand and _kind(field_type.split("[")[0]) == "message" \
            else None
        if nested is not None:
            lines += _definition_lines(nested, expand, indent + "  ")
    return lines


def _constants(cls: type) -> list[tuple[str, Any]]:
    """A message's constants (``GoalStatus.PENDING``): upper-case class attributes holding plain values."""
    fields = set(field_types(cls)[0])
    found = []
    for name in dir(cls):
        if name.isupper() and not name.startswith("_") and name.lower() not in fields:
            value = getattr(cls, name, None)
            if isinstance(value, (bool, int, float, str)):
                found.append((name, value))
    return found


def to_yaml(msg: Any, noarr: bool = False, offset: bool = False) -> str:
    """A message as the block YAML ``rostopic echo`` and ``ros2 topic echo`` print (``%pub`` reads it back).

    As ``rostopic echo``'s options: ``noarr`` shows arrays as ``<array of N float64>``, ``offset``
    shows times as seconds from now (``-0.0213``: how old a stamp is).
    """
    if not _is_message(msg) or _is_ros1_message(msg) and not (noarr or offset):
        return str(msg)  # a field's value; or genpy's own YAML, as rostopic prints it
    data = _as_data(msg, noarr=noarr, now=time.time() if offset else None)
    return yaml.safe_dump(data, default_flow_style=False, width=1 << 20, sort_keys=False).strip()


def as_data(msg: Any) -> Any:
    """A message as plain data (dicts of fields, times as {secs, nsecs}, bytes as lists): what a file keeps."""
    return _as_data(msg)


def flow_yaml(msg: Any) -> str:
    """A message as one line of YAML (flow style), the same on both ROS: ``{linear: {x: 1.0, y: 0.0, z: 0.0}, ...}``."""
    return yaml.safe_dump(_as_data(msg), default_flow_style=True, width=1 << 20, sort_keys=False).strip()


def flat_fields(msg: Any) -> dict[str, Any]:
    """A message's leaf fields by dotted path (``linear.x``), in order: one row of a CSV or a table.
    Arrays stay whole (a list), so that a row keeps one column per field."""
    flat: dict[str, Any] = {}

    def walk(value: Any, path: str) -> None:
        if isinstance(value, dict):
            for key, item in value.items():
                walk(item, f"{path}.{key}" if path else key)
        else:
            flat[path] = value

    walk(_as_data(msg), "")
    return flat


def copy_message(msg: Any) -> Any:
    """A deep copy of a message of either ROS: ``copy.deepcopy`` goes through pickling's ``__reduce_ex__`` for every
    nested message and array (about 100 µs for a ``TwistStamped``), and a try over a whole bag copies each message
    for each handler. Each class gets a copier of its own, generated once as straight-line code from its fields
    (about 1 µs for a ``TwistStamped``); a value that is not what its field declares is copied the slow, general
    way. Anything that is no message is left to ``copy.deepcopy``."""
    copier = _COPIERS.get(type(msg))
    if copier is not None:
        return copier(msg)
    if not _is_message(msg):
        return _copy_value(msg)
    return _copier(type(msg))(msg)


_IMMUTABLE = (bool, int, float, str, bytes, type(None))
_MISSING = object()
_COPIERS: dict[type, Any] = {}


def _copier(cls: type) -> Any:
    """``copy(msg)`` for messages of ``cls``, made once (see :func:`copy_message`). A nested message is copied by the
    copier of its own class, as it is at run time (a bag's messages are of classes made from the bag's definitions,
    not the installed ones)."""
    found = _COPIERS.get(cls)
    if found is not None:
        return found
    import array

    names, types = field_types(cls)
    slots = list(getattr(cls, "__slots__", ()))
    scope: dict[str, Any] = {"new": cls.__new__, "cls": cls, "IMM": frozenset(_IMMUTABLE), "slow": _copy_value,
                             "SEQ": frozenset((list, tuple, bytes, array.array)), "stamp": _copy_stamp,
                             "COP": _COPIERS, "message": copy_message, "MISSING": _MISSING}  # (a set: one hash)
    lines = ["def copy(m):", "    n = new(cls)"]
    fielded = set()
    for name, kind in zip(names, types):
        slot = name if name in slots else f"_{name}" if f"_{name}" in slots else None
        if slot is None or not slot.isidentifier():
            continue
        fielded.add(slot)
        array_ = _ARRAY.match(kind)
        base = array_["base"] if array_ else kind
        lines.append(f"    v = m.{slot}")
        if base in ("time", "duration"):
            lines.append(f"    n.{slot} = [stamp(x) for x in v] if type(v) is list else slow(v)" if array_ else
                         f"    n.{slot} = stamp(v)")
        elif base not in _PRIMITIVE_TYPES:  # a message, or a list of them
            element = "(COP.get(type(x)) or message)(x)"
            lines.append(f"    n.{slot} = [{element} for x in v] if type(v) is list else slow(v)" if array_ else
                         f"    n.{slot} = (COP.get(type(v)) or message)(v)")
        elif array_:  # a new list (a tuple or bytes is as good as new; array.array sliced is a copy; numpy: slow)
            lines.append(f"    n.{slot} = v[:] if type(v) in SEQ else slow(v)")
        else:
            lines.append(f"    n.{slot} = v if type(v) in IMM else slow(v)")
    for slot in slots:  # what is no field (ROS 2's _check_fields): as it is
        if slot not in fielded and slot.isidentifier():
            lines += [f"    v = getattr(m, {slot!r}, MISSING)",
                      f"    if v is not MISSING: n.{slot} = v if type(v) in IMM else slow(v)"]
    lines.append("    return n")
    exec("\n".join(lines), scope)  # noqa: S102 - our own code, from the class's field names
    found = _COPIERS[cls] = scope["copy"]
    return found


def same_message(a: Any, b: Any) -> bool:
    """Whether two messages are equal, as ``a == b`` says, faster: genpy's ``__eq__`` walks each nested message's
    slots through ``getattr`` (about 1.2 µs for a ``TwistStamped``, and a try over a bag compares what both handlers
    wrote for every message). Each class gets a comparer of its own, generated once as straight-line code from its
    fields; an array, a stamp, or a value of another class than its field declares is compared by ``==``."""
    comparer = _COMPARERS.get(type(a))
    if comparer is None:
        if not _is_message(a):
            return bool(a == b)
        comparer = _comparer(type(a))
    return comparer(a, b)


_COMPARERS: dict[type, Any] = {}


def _comparer(cls: type) -> Any:
    """``same(a, b)`` for an ``a`` of ``cls`` (see :func:`same_message`), made once."""
    found = _COMPARERS.get(cls)
    if found is not None:
        return found
    names, types = field_types(cls)
    slots = set(getattr(cls, "__slots__", ()))
    terms = []
    for name, kind in zip(names, types):
        slot = name if name in slots else f"_{name}" if f"_{name}" in slots else None
        if slot is None or not slot.isidentifier():
            return _general_comparer(cls)  # a field that is no slot: the class's own ==
        if _ARRAY.match(kind) or kind in ("time", "duration") or kind in _PRIMITIVE_TYPES:
            terms.append(f"same(a.{slot}, b.{slot})" if _ARRAY.match(kind) else f"a.{slot} == b.{slot}")
        else:  # a nested message: its own comparer, as the value's class is at run time
            terms.append(f"(COMP.get(type(a.{slot})) or message)(a.{slot}, b.{slot})")
    lines = ["def same(a, b):", "    if type(b) is not cls:", "        return bool(a == b)",
             f"    return bool({' and '.join(terms) or 'True'})"]
    scope: dict[str, Any] = {"cls": cls, "COMP": _COMPARERS, "message": same_message, "same": _same_value}
    exec("\n".join(lines), scope)  # noqa: S102 - our own code, from the class's field names
    found = _COMPARERS[cls] = scope["same"]
    return found


def _general_comparer(cls: type) -> Any:
    def same(a: Any, b: Any) -> bool:
        return bool(a == b)

    _COMPARERS[cls] = same
    return same


def _same_value(a: Any, b: Any) -> bool:
    """``a == b`` for an array's values of either ROS (a numpy array's ``==`` is an array of its own)."""
    if type(a) in (list, tuple, bytes) and type(b) in (list, tuple, bytes):
        return bool(a == b) if type(a) is type(b) else list(a) == list(b)
    equal = a == b
    if isinstance(equal, bool):
        return equal
    try:
        return len(a) == len(b) and bool(equal.all())
    except (AttributeError, TypeError):
        return bool(equal)


_STAMPS: dict[type, bool] = {}  # type → whether it is a ROS 1 time or duration (genpy's)


def _copy_stamp(value: Any) -> Any:
    """A ROS 1 time or duration (genpy's ``TVal``: two numbers in slots), made again without its constructor's
    checks; a ROS 2 stamp is a message; anything else is copied the general way."""
    kind = type(value)
    known = _STAMPS.get(kind)
    if known is None:
        known = _STAMPS[kind] = _is_ros1_stamp(value) and set(getattr(kind, "__slots__", ())) >= {"secs", "nsecs"}
    if known:
        new: Any = object.__new__(kind)
        new.secs, new.nsecs = value.secs, value.nsecs
        return new
    return _copy_value(value)


def _copy_value(value: Any) -> Any:
    if value is None or isinstance(value, (bool, int, float, str, bytes)):
        return value
    if isinstance(value, list):
        return [_copy_value(item) for item in value]
    if _is_message(value):
        return copy_message(value)
    return copy.deepcopy(value)  # stamps, arrays (array.array, numpy), tuples of messages, anything else


def fields_of(msg: Any) -> list[str]:
    """A message's (or message class's) field names, in order, on either ROS (and as rosbags reads a bag's:
    dataclasses, whose fields name the message's)."""
    cls = msg if isinstance(msg, type) else type(msg)
    ros2_fields = getattr(cls, "get_fields_and_field_types", None)
    if ros2_fields is not None:
        return list(ros2_fields())
    dataclass_fields = getattr(cls, "__dataclass_fields__", None)
    if dataclass_fields is not None and not hasattr(cls, "_slot_types"):
        return [name for name in dataclass_fields if not name.startswith("__")]
    return list(getattr(cls, "__slots__", ()))


def _is_message(value: Any) -> bool:
    """A message of either ROS: ROS 2's classes list their fields; ROS 1's (genpy's) their slots' types."""
    return hasattr(type(value), "get_fields_and_field_types") or _is_ros1_message(value)


def _is_ros1_message(value: Any) -> bool:
    # By its shape, not isinstance(genpy.Message): the core imports no ROS library.
    return hasattr(type(value), "_slot_types") and hasattr(type(value), "_md5sum")


def _is_ros1_stamp(value: Any) -> bool:
    """A ROS 1 time or duration (genpy's ``TVal``: secs and nsecs)."""
    return hasattr(value, "nsecs") and hasattr(value, "to_sec")


@functools.cache
def _stamp_class(field_type: str) -> Any:
    """ROS 1's Time or Duration class, as its std_msgs make them (the core imports no ROS library;
    ``time`` and ``duration`` fields are ROS 1's only, and std_msgs is there wherever they are)."""
    if field_type == "time":
        return type(msgtypes.resolve_message("std_msgs/Header")[1]().stamp)
    return type(msgtypes.resolve_message("std_msgs/Duration")[1]().data)


def _as_data(value: Any, noarr: bool = False, now: Any = None) -> Any:
    """A message as plain data: dicts of fields, times as {secs, nsecs}, byte arrays as lists.

    ``noarr``: arrays as ``<array of N type>``; ``now`` (seconds): times as seconds from it."""
    if now is not None and _is_time(value):
        return round(_seconds(value) - now, 6)
    if _is_message(value):
        return {name: _as_data(getattr(value, name), noarr, now) for name in fields_of(value)}
    if _is_ros1_stamp(value):
        return {"secs": value.secs, "nsecs": value.nsecs}
    if noarr and isinstance(value, (bytes, bytearray, list, tuple)) or noarr and hasattr(value, "tolist") and \
            hasattr(value, "__len__"):
        items = value.tolist() if hasattr(value, "tolist") else value
        kind = type(items[0]).__name__ if len(items) else "items"
        return f"<array of {len(items)} {kind}>"
    if isinstance(value, (bytes, bytearray)):
        return list(value)
    if isinstance(value, (list, tuple)):
        return [_as_data(item, noarr, now) for item in value]
    if hasattr(value, "tolist"):  # ROS 2 arrays: array.array, numpy (a float64 scalar too)
        return _as_data(value.tolist(), noarr, now)
    return value


def _is_time(value: Any) -> bool:
    """A point in time: ROS 1's rospy.Time, ROS 2's builtin_interfaces/Time."""
    if _is_ros1_stamp(value):
        return type(value).__name__ == "Time"
    return type(value).__name__ == "Time" and type(value).__module__.startswith("builtin_interfaces")


def _seconds(stamp: Any) -> float:
    if hasattr(stamp, "secs"):
        return stamp.secs + stamp.nsecs * 1e-9
    return stamp.sec + stamp.nanosec * 1e-9


class _FieldError(Exception):
    """A problem at a field path; :func:`build_message` prefixes the type name."""

    def __init__(self, path: str, problem: str) -> None:
        super().__init__(f"{path}: {problem}" if path else problem)


class _Builder:
    """Builds a message field by field, every value checked; ``nonfinite`` lets NaN and inf through."""

    def __init__(self, nonfinite: bool) -> None:
        self.nonfinite = nonfinite

    def message(self, cls: type, data: Any, path: str) -> Any:
        if isinstance(data, cls):
            return data
        name = msgtypes.type_name(cls)
        if _is_message(data):
            raise _FieldError(path, f"expected a {name}, got a {msgtypes.type_name(type(data))}")
        fields, types = field_types(cls)
        if data is None:
            return cls()
        if isinstance(data, dict):
            values = {}
            for key, value in data.items():
                if key not in fields:
                    where = _join(path, str(key))
                    raise _FieldError(where, f"no such field ({name} has {', '.join(fields) or 'no fields'})")
                values[key] = self.value(types[fields.index(key)], value, _join(path, key))
            return cls(**values)
        if isinstance(data, (list, tuple)):
            if len(data) != len(fields):
                raise _FieldError(path, f"{len(data)} values for {name}, which has {len(fields)} fields "
                                        f"({', '.join(fields)}); give all of them in order, or a dict")
            return cls(**{f: self.value(t, v, _join(path, f)) for f, t, v in zip(fields, types, data)})
        if len(fields) == 1:  # "hello" for std_msgs/String, 3 for std_msgs/Int32
            return cls(**{fields[0]: self.value(types[0], data, _join(path, fields[0]))})
        raise _FieldError(path, f"expected a dict of fields for {name} ({', '.join(fields)}), "
                                f"got {_describe(data)}")

    def value(self, field_type: str, value: Any, path: str) -> Any:
        """``value`` checked (and converted where lossless) for a field of ``field_type``."""
        array = _ARRAY.match(field_type)
        if array:
            return self.array(array["base"], int(array["size"]) if array["size"] else None, value, path)
        if field_type in _INT_BITS or field_type in _UINT_BITS:
            return _integer(field_type, value, path)
        if field_type in _FLOATS:
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise _FieldError(path, f"expected a number ({field_type}), got {_describe(value)}")
            if not self.nonfinite and not math.isfinite(value):
                raise _FieldError(path, f"{value} is not a number a robot can use; give a finite number "
                                        "(or, if it is meant, e.g. a Range's inf, allow it: %pub --nonfinite)")
            if field_type == "float32" and not _float32_fits(value):
                raise _FieldError(path, _float32_range(value))
            return float(value)
        if field_type == "bool":
            if not isinstance(value, bool):
                raise _FieldError(path, f"expected True or False, got {_describe(value)}")
            return value
        if field_type == "string":
            if not isinstance(value, str):
                raise _FieldError(path, f"expected a string, got {_describe(value)}; quote it")
            return value
        if field_type in ("time", "duration"):
            return _stamp(field_type, value, path)
        if "/" not in field_type:  # "Header" in very old messages
            field_type = "std_msgs/Header" if field_type == "Header" else field_type
        try:
            _, cls = msgtypes.resolve_message(field_type)
        except MessageTypeError as error:
            raise _FieldError(path, str(error)) from None
        return self.message(cls, value, path)

    def array(self, base: str, size: int | None, value: Any, path: str) -> Any:
        if base in ("uint8", "char") and isinstance(value, (bytes, bytearray)):
            items: Any = bytes(value)
        elif isinstance(value, (list, tuple)):
            items = [self.value(base, v, f"{path}[{i}]") for i, v in enumerate(value)]
            if base in ("uint8", "char"):  # genpy wants bytes for uint8[]
                items = bytes(items)
        else:
            raise _FieldError(path, f"expected a list of {base}, got {_describe(value)}")
        if size is not None and len(items) != size:
            raise _FieldError(path, f"expected exactly {size} values ({base}[{size}]), got {len(items)}")
        return items


#: ROS 2's names of the primitive types (its IDL's), as the builder knows them (ROS 1's).
_ROS2_PRIMITIVES = {"double": "float64", "float": "float32", "boolean": "bool", "octet": "uint8",
                    "wstring": "string", "long double": "float64"}
_ROS2_SEQUENCE = re.compile(r"^sequence<(?P<base>[^,>]+)(?:, *\d+)?>$")


def field_types(cls: type) -> tuple[list[str], list[str]]:
    """A message class's field names and their types, in ROS 1's spelling on either ROS
    (``sequence<double>`` is ``float64[]``, ``string<=10`` is ``string``, ...)."""
    ros2_fields = getattr(cls, "get_fields_and_field_types", None)
    if ros2_fields is None:
        return list(cls.__slots__), list(cls._slot_types)  # type: ignore[attr-defined]
    return list(ros2_fields()), [_ros1_spelling(t) for t in ros2_fields().values()]


def _ros1_spelling(field_type: str) -> str:
    sequence = _ROS2_SEQUENCE.match(field_type)
    if sequence:
        return _ros1_spelling(sequence["base"].strip()) + "[]"
    array = _ARRAY.match(field_type)
    if array:
        return _ros1_spelling(array["base"]) + f"[{array['size']}]"
    if field_type.startswith(("string<=", "wstring<=")):
        return "string"
    return _ROS2_PRIMITIVES.get(field_type, field_type)


def _integer(field_type: str, value: Any, path: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise _FieldError(path, f"expected an integer ({field_type}), got {_describe(value)}")
    low, high = _integer_range(field_type)
    if not low <= value <= high:
        raise _FieldError(path, f"{value} is out of range for {field_type} ({low}..{high})")
    return value


def _stamp(field_type: str, value: Any, path: str) -> Any:
    cls = _stamp_class(field_type)
    if isinstance(value, cls):
        return value
    if field_type == "time" and value == "now":
        return cls.from_sec(time.time())  # wall clock: sim time needs the ROS node
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        if field_type == "time" and value < 0:
            raise _FieldError(path, f"a time cannot be negative, got {value}")
        limit = (1 << 32) if field_type == "time" else (1 << 31)
        if not -limit <= value < limit:  # NaN fails this too
            raise _FieldError(path, f"{value} does not fit a {field_type} (up to {limit - 1} s)")
        return cls.from_sec(value)
    if isinstance(value, dict) and set(value) <= {"secs", "nsecs"} and value:
        secs, nsecs = value.get("secs", 0), value.get("nsecs", 0)
        for key, part in (("secs", secs), ("nsecs", nsecs)):
            if isinstance(part, bool) or not isinstance(part, int):
                raise _FieldError(_join(path, key), f"expected an integer, got {_describe(part)}")
        high = (1 << 32) - 1 if field_type == "time" else (1 << 31) - 1
        low = 0 if field_type == "time" else -(1 << 31)
        if not low <= secs <= high:
            raise _FieldError(_join(path, "secs"), f"{secs} does not fit a {field_type} ({low}..{high} s)")
        return cls(secs, nsecs)
    now = " or 'now'" if field_type == "time" else ""
    raise _FieldError(path, f"expected seconds (a number), {{secs: S, nsecs: N}}{now} for a {field_type}, "
                            f"got {_describe(value)}")


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


def _describe(value: Any) -> str:
    if _is_message(value):
        return f"a {msgtypes.type_name(value)} message"
    text = " ".join(repr(value).split())
    if len(text) > 40:
        text = text[:37] + "..."
    return f"{text} ({type(value).__name__})"


# -- a message object as a handler built it: checked before it is sent ------------------------------

def conform(msg: Any) -> Any:
    """``msg`` made fit to send, or a :class:`MessageTypeError` naming the first field that cannot be.

    A message a handler builds is not checked by the ROS client library the way
    :func:`build_message` checks data: rclpy checks field types only with
    ``ROS_PYTHON_CHECK_FIELDS`` set, and its C conversion reads an ``int`` put in a float
    field as the bits of a double (``Vector3(x=1)`` arrives as ``x=5e-324``), a string
    in a ``bool`` field as False, an integer too large for its field cut to its low bits.
    So before a message leaves, every scalar field is checked against its declared type:
    an integer in a float field becomes that float (as ROS 1 does), anything else that
    does not fit is refused in one line naming the field's path. Arrays of numbers are
    left alone: the message classes convert (or refuse) what is assigned to them, so a
    1 MiB image costs nothing here.
    """
    _conform(msg, "")
    return msg


def explain_unsendable(msg: Any) -> str | None:
    """Why ``msg`` cannot be serialised, by field path, if a field is to blame (for ROS 1's error line)."""
    try:
        _conform(msg, "")
    except MessageTypeError as error:
        return str(error)
    return None


def _conform(msg: Any, path: str) -> None:
    _checker(type(msg))(msg, path)


_CHECKERS: dict[type, Any] = {}


def _checker(cls: type) -> Any:
    """``check(msg, path)`` for messages of ``cls``: made once per class, as straight-line code.

    A check runs before every message a handler sends on ROS 2, so it is generated per
    class (one ``type(v) is float`` test per float field, a call per nested message)
    rather than interpreted from the field list each time: about a microsecond for a
    TwistStamped.
    """
    found = _CHECKERS.get(cls)
    if found is not None:
        return found
    fields, types = field_types(cls)
    scope: dict[str, Any] = {"_conform": _conform, "_fix": _fix, "_ok": _int_fits, "_f32": _float32_fits}
    lines = ["def check(m, p):"]
    for i, (name, field_type) in enumerate(zip(fields, types)):
        if not name.isidentifier():
            continue
        kind = _kind(field_type)
        if kind is None:
            continue
        scope[f"t{i}"] = field_type
        if kind == "float":
            extra = "" if field_type != "float32" else f" or not _f32(m.{name})"
            lines.append(f"    if type(m.{name}) is not float{extra}: m.{name} = _fix(t{i}, m.{name}, p + {name!r})")
        elif kind in ("int", "bool", "string"):
            want = {"int": "int", "bool": "bool", "string": "str"}[kind]
            extra = "" if kind != "int" else f" or not _ok(t{i}, m.{name})"
            lines.append(f"    if type(m.{name}) is not {want}{extra}: m.{name} = _fix(t{i}, m.{name}, p + {name!r})")
        elif kind == "message":
            nested = scope[f"c{i}"] = nested_class(field_type)
            scope[f"k{i}"] = _checker(nested) if nested is not None else None
            lines.append(f"    v = m.{name}")
            lines.append(f"    if type(v) is not c{i}: _fix(t{i}, v, p + {name!r})")
            lines.append(f"    k{i}(v, p + {name + '.'!r})" if nested is not None else
                         f"    _conform(v, p + {name + '.'!r})")
        else:  # a list of strings or of messages
            lines.append(f"    _fix(t{i}, m.{name}, p + {name!r})")
    lines.append("    return None")
    exec("\n".join(lines), scope)  # noqa: S102 - our own code, from the class's field names
    found = _CHECKERS[cls] = scope["check"]
    return found


def _kind(field_type: str) -> str | None:
    """What :func:`_checker` checks in a field of ``field_type`` (ROS 1's spelling); None: nothing."""
    array = _ARRAY.match(field_type)
    if array:
        base = array["base"]
        if base in _INT_BITS or base in _UINT_BITS or base in _FLOATS or base in ("bool", "time", "duration",
                                                                                   "char", "byte"):
            return None  # array.array / numpy / bytes: converted or refused when assigned
        return "list"
    if field_type in _FLOATS:
        return "float"
    if field_type in _INT_BITS or field_type in _UINT_BITS:
        return "int"
    if field_type in ("bool", "string"):
        return field_type
    if field_type in ("time", "duration") or "/" not in field_type and field_type != "Header":
        return None
    return "message"


def nested_class(field_type: str) -> Any:
    """The class of a nested message field, or None if it cannot be imported here (then checked by kind)."""
    try:
        return msgtypes.resolve_message("std_msgs/Header" if field_type == "Header" else field_type)[1]
    except MessageTypeError:
        return None


def _integer_range(field_type: str) -> tuple[int, int]:
    if field_type in _UINT_BITS:
        return 0, (1 << _UINT_BITS[field_type]) - 1
    half = 1 << (_INT_BITS[field_type] - 1)
    return -half, half - 1


def _float32_fits(value: float) -> bool:
    """Whether ``value`` is a float32 as it is: an infinity or a NaN is (what a guard makes of it is the guard's)."""
    return -FLOAT32_MAX <= value <= FLOAT32_MAX or not math.isfinite(value)


def _float32_range(value: float) -> str:
    return f"{value:g} is out of range for float32 (-{FLOAT32_MAX:.6g}..{FLOAT32_MAX:.6g})"


def _int_fits(field_type: str, value: int) -> bool:
    low, high = _integer_range(field_type)
    return low <= value <= high


def _short_type(field_type: str) -> str:
    """``std_msgs/Header`` for ``Header`` (very old messages), else the type as given (``pkg/Type``)."""
    return "std_msgs/Header" if field_type == "Header" else field_type


def _refuse(path: str, expected: str, value: Any) -> MessageTypeError:
    return MessageTypeError(f"{path}: expected {expected}, got {_describe(value)}; nothing was sent")


def _fix(field_type: str, value: Any, path: str) -> Any:
    """The value to send for a field whose quick check failed: converted where lossless, else refused."""
    kind = _kind(field_type)
    if kind == "float":
        if isinstance(value, (bool, str, bytes)) or not isinstance(value, (int, float)) and \
                not hasattr(value, "__float__"):
            raise _refuse(path, f"a number ({field_type})", value)
        value = float(value)  # an int, or numpy's float32
        if field_type == "float32" and not _float32_fits(value):
            raise MessageTypeError(f"{path}: {_float32_range(value)}; nothing was sent")
        return value
    if kind == "int":
        if isinstance(value, (bool, float, str, bytes)) or not hasattr(value, "__index__"):
            raise _refuse(path, f"an integer ({field_type})", value)
        value = int(value)  # numpy's integers
        if not _int_fits(field_type, value):
            low, high = _integer_range(field_type)
            raise MessageTypeError(f"{path}: {value} is out of range for {field_type} ({low}..{high}); "
                                   "nothing was sent")
        return value
    if kind == "bool":
        if not isinstance(value, (str, bytes, float)) and value in (0, 1):
            return bool(value)
        raise _refuse(path, "True or False", value)
    if kind == "string":
        raise _refuse(path, "a string", value)
    if kind == "message":
        if not _is_message(value) or msgtypes.type_name(value) != _short_type(field_type):
            raise _refuse(path, f"a {_short_type(field_type)}", value)
        return value
    base = field_type.split("[")[0]
    if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
        raise _refuse(path, f"a list of {base}", value)
    for i, item in enumerate(value):
        if base == "string":
            if not isinstance(item, str):
                raise _refuse(f"{path}[{i}]", "a string", item)
        elif not _is_message(item) or msgtypes.type_name(item) != _short_type(base):
            raise _refuse(f"{path}[{i}]", f"a {_short_type(base)}", item)
        else:
            _conform(item, f"{path}[{i}].")
    return value
