"""A message's numbers read straight from its serialized bytes, where its type's layout allows (pure: no ROS).

A guarded relay must know whether each message passes its guard as it came: every float finite, every limited
field within its bounds. Deserialising a message into an object, checking it and serialising it again costs more
than the relay itself; reading the few numbers at their places in the bytes, and forwarding the bytes unchanged
when nothing is to be done, costs a few microseconds. Only a message the guard acts on is then read whole.

Two encodings: ROS 1's (little-endian, packed: no padding) and ROS 2's CDR (a 4-byte encapsulation header, then
each primitive aligned to its size, up to 8, counted from the end of that header; only little-endian plain CDR is
read here). A string is a length then its bytes (CDR counts its closing NUL), a sequence a count then its
elements, a fixed array its elements alone, a nested message its fields in order. A type with an array of messages,
or a fixed-size array of strings or of times, has no :class:`Layout`: its messages are read whole.

    layout = wire.layout(TwistStamped, wire.CDR)
    layout.names           # ("header.stamp.sec", ..., "twist.linear.x", ...): each scalar number, in order
    layout.read(raw)       # their values; None if a float is not finite or the bytes are not as expected
"""

from __future__ import annotations

import math
import operator
import re
import struct
from typing import Any, Callable, Optional, Sequence, Union

from .msgbuild import field_types, nested_class

__all__ = ["CDR", "ROS1", "Layout", "layout"]

#: The two encodings: ROS 1's, and ROS 2's CDR.
ROS1, CDR = "ros1", "cdr"
#: The encapsulation header of little-endian plain CDR, the one read here.
_CDR_LE = b"\x00\x01"

#: Each primitive: its struct code (little-endian) and whether it is a float. ROS 1's ``time`` and ``duration`` are
#: two 32-bit integers each; ROS 2's are messages of their own (``builtin_interfaces/Time``).
_PRIMITIVES: dict[str, tuple[str, bool]] = {
    "bool": ("?", False), "byte": ("b", False), "char": ("B", False), "int8": ("b", False), "uint8": ("B", False),
    "int16": ("h", False), "uint16": ("H", False), "int32": ("i", False), "uint32": ("I", False),
    "int64": ("q", False), "uint64": ("Q", False), "float32": ("f", True), "float64": ("d", True),
    "time": ("II", False), "duration": ("ii", False)}
_ARRAY = re.compile(r"^(?P<base>[^\[\]]+)\[(?P<size>\d*)\]$")
_SIZES = {"?": 1, "b": 1, "B": 1, "h": 2, "H": 2, "i": 4, "I": 4, "q": 8, "Q": 8, "f": 4, "d": 8}
_COUNT = struct.Struct("<I")


class _Run:
    """Scalars one after another: their struct for each position the run may start at (CDR pads each to its size,
    so the padding depends on where the run begins; ROS 1 has none), and which of them are floats."""

    def __init__(self, codes: Sequence[str], cdr: bool) -> None:
        self.codes, self.cdr = list(codes), cdr
        self.floats = [i for i, code in enumerate(self.codes) if code in "fd"]
        self._by_start: dict[int, tuple[struct.Struct, int]] = {}

    def read(self, raw: Any, at: int, base: int) -> tuple[tuple[Any, ...], int]:
        """The run's values from ``raw`` at ``at`` (``base``: where CDR's alignment counts from), and where it ends."""
        start = (at - base) % 8 if self.cdr else 0
        made = self._by_start.get(start)
        if made is None:
            made = self._by_start[start] = self._struct(start)
        packed, size = made
        return packed.unpack_from(raw, at), at + size

    def _struct(self, start: int) -> tuple[struct.Struct, int]:
        fmt, pos = "<", start
        for code in self.codes:
            size = _SIZES[code]
            if self.cdr and pos % size:
                fmt += f"{size - pos % size}x"
                pos += size - pos % size
            fmt += code
            pos += size
        return struct.Struct(fmt), pos - start


class _Skip:
    """A string, or a sequence of strings: only its length matters here."""

    def __init__(self, strings: bool, cdr: bool) -> None:
        self.strings, self.cdr = strings, cdr

    def skip_string(self, raw: Any, at: int, base: int) -> int:
        if self.cdr:
            at += -(at - base) % 4
        (length,) = _COUNT.unpack_from(raw, at)
        return at + 4 + length

    def read(self, raw: Any, at: int, base: int) -> int:
        if not self.strings:
            return self.skip_string(raw, at, base)
        if self.cdr:
            at += -(at - base) % 4
        (count,) = _COUNT.unpack_from(raw, at)
        at += 4
        for _ in range(count):
            at = self.skip_string(raw, at, base)
        return at


class _Numbers:
    """A sequence of numbers (``float64[]``, ``uint8[]``): its count, then its elements; floats checked finite."""

    def __init__(self, code: str, cdr: bool) -> None:
        self.code, self.size, self.cdr = code, _SIZES[code], cdr
        self.floats = code in "fd"

    def read(self, raw: Any, at: int, base: int) -> tuple[bool, int]:
        if self.cdr:
            at += -(at - base) % 4
        (count,) = _COUNT.unpack_from(raw, at)
        at += 4
        if count and self.cdr:
            at += -(at - base) % self.size
        end = at + count * self.size
        if end > len(raw):
            raise struct.error("a sequence runs past the message's end")
        finite = not self.floats or all(map(math.isfinite, struct.unpack_from(f"<{count}{self.code}", raw, at)))
        return finite, end


_Step = Union[_Run, _Skip, _Numbers]


class Layout:
    """Where a type's numbers lie in its serialized bytes (see the module's docstring); made by :func:`layout`."""

    def __init__(self, names: Sequence[str], steps: Sequence[_Step], cdr: bool) -> None:
        #: The dotted path of each scalar number :meth:`read` gives, in order (array elements are checked finite,
        #: not named: a guard limiting one reads the message whole).
        self.names = tuple(names)
        self._steps, self._cdr = list(steps), cdr
        #: ROS 1's bytes have no padding, so each run's struct is known before a message comes: the steps made
        #: ready for :meth:`_read_packed` (a run's struct, its size, how its floats are summed; or the step).
        self._packed = None if cdr else [_packed(step) for step in steps]

    def read(self, raw: Any) -> Optional[list[Any]]:
        """The scalar numbers of the serialized message ``raw``, in :attr:`names`' order; None when a float anywhere
        in it (an array's too) is not finite, or the bytes are not what its type lays out (too short, another
        encapsulation): the message is then read whole."""
        if self._packed is not None:
            return self._read_packed(raw)
        cdr = self._cdr
        if cdr and raw[:2] != _CDR_LE:
            return None
        base = 4 if cdr else 0
        at, values = base, list[Any]()
        try:
            for step in self._steps:
                if isinstance(step, _Run):
                    found, at = step.read(raw, at, base)
                    for i in step.floats:
                        if not math.isfinite(found[i]):
                            return None
                    values.extend(found)
                elif isinstance(step, _Numbers):
                    finite, at = step.read(raw, at, base)
                    if not finite:
                        return None
                else:
                    at = step.read(raw, at, base)
        except struct.error:
            return None
        return values if at <= len(raw) else None


    def _read_packed(self, raw: Any) -> Optional[list[Any]]:
        """:meth:`read` for ROS 1's packed bytes, where a guarded relay reads every message: each run unpacked by the
        struct made for it, its floats checked finite by their sum (finite only if each is; finite floats whose sum
        overflows are read whole, as a NaN is: slower, never wrong)."""
        at, values = 0, list[Any]()
        try:
            for packed, size, floats, step in self._packed or ():
                if packed is not None:
                    found = packed.unpack_from(raw, at)
                    at += size
                    if floats is not None and not math.isfinite(sum(floats(found))):
                        return None
                    values += found
                elif isinstance(step, _Numbers):
                    finite, at = step.read(raw, at, 0)
                    if not finite:
                        return None
                elif isinstance(step, _Skip):  # a string: its length, then its bytes; or a sequence of them
                    at = step.read(raw, at, 0) if step.strings else at + 4 + _COUNT.unpack_from(raw, at)[0]
        except struct.error:
            return None
        return values if at <= len(raw) else None


def _packed(step: _Step) -> tuple[Optional[struct.Struct], int, Optional[Callable[[tuple], Sequence[float]]], _Step]:
    """A step of ROS 1's layout made ready to read: a run's struct, its size and what picks its floats (None: it has
    none); other steps as they are."""
    if not isinstance(step, _Run):
        return None, 0, None, step
    packed, size = step._struct(0)
    floats = step.floats
    if not floats:
        return packed, size, None, step
    if len(floats) == len(step.codes):
        return packed, size, lambda found: found, step
    pick = operator.itemgetter(*floats)
    return packed, size, (lambda found: (pick(found),)) if len(floats) == 1 else pick, step


def layout(cls: type, encoding: str) -> Optional[Layout]:
    """The :class:`Layout` of message class ``cls`` in ``encoding`` (:data:`ROS1` or :data:`CDR`); None if its
    messages must be read whole (an array of messages, a type not known here)."""
    cdr = encoding == CDR
    names: list[str] = []
    steps: list[_Step] = []
    codes: list[str] = []

    def close_run() -> None:
        if codes:
            steps.append(_Run(codes[:], cdr))
            codes.clear()

    def walk(kind: type, prefix: str, depth: int) -> bool:
        if depth > 16:
            return False
        for name, field in zip(*field_types(kind)):
            path = f"{prefix}{name}"
            array = _ARRAY.match(field)
            base = array["base"] if array else field
            primitive = _PRIMITIVES.get(base)
            if array is None and primitive is not None:
                codes.extend(primitive[0])
                names.extend([path] if len(primitive[0]) == 1 else [f"{path}.secs", f"{path}.nsecs"])
            elif array is None and base == "string":
                close_run()
                steps.append(_Skip(False, cdr))
            elif array is not None and base == "string" and not array["size"]:
                close_run()
                steps.append(_Skip(True, cdr))
            elif array is not None and primitive is not None and len(primitive[0]) == 1 and not array["size"]:
                close_run()
                steps.append(_Numbers(primitive[0], cdr))
            elif array is not None and primitive is not None and len(primitive[0]) == 1:
                codes.extend(primitive[0] * int(array["size"]))
                names.extend(f"{path}[{i}]" for i in range(int(array["size"])))
            elif array is None and primitive is None:
                nested = nested_class(base)
                if nested is None or not walk(nested, f"{path}.", depth + 1):
                    return False
            else:
                return False  # an array of messages, of strings of a fixed count, of times
        return True

    if not walk(cls, "", 0):
        return None
    close_run()
    return Layout(names, steps, cdr)
