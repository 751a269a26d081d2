"""What the C++ a ROS 1 export writes is made of: a message type's C++ name, an identifier from a ROS name, a string
literal, the genpy class a type's fields are read from, and the code that reaches every value a field path names."""

from __future__ import annotations

import json
import re
from typing import Any

from ..core.errors import IpyrosError

__all__ = ["cpp_type", "ident", "indent", "message_class", "string", "visit"]


def cpp_type(type_name: str) -> str:
    package, name = type_name.split("/")
    return f"{package}::{name}"


def ident(text: str) -> str:
    """A C++ identifier made from a ROS name (``/robot/cmd_vel`` → ``robot_cmd_vel``)."""
    return re.sub(r"\W+", "_", text).strip("_") or "root"


def string(text: str) -> str:
    """A C++ string literal (JSON's escapes are C++'s for these)."""
    return json.dumps(text)


def message_class(type_name: str) -> Any:
    import roslib.message

    cls = roslib.message.get_message_class(type_name)
    if cls is None:
        raise IpyrosError(f"the C++ export needs the message {type_name}, which this Python cannot import: "
                          "install its package")
    return cls


def visit(cls: Any, path: str, root: str, act: Any) -> str:
    """C++ that does ``act(place, lvalue)`` on every value ``path`` names in the message ``root`` (a type ``cls``):
    ``linear.x``, ``axes[2]`` (if the array has it), ``poses[*].position.x`` (each element)."""
    steps = path.strip().split(".")
    lines: list[str] = []
    expr, depth, place = root, 0, "0"
    for number, step in enumerate(steps):
        name, _, index = step.partition("[")
        index = index.rstrip("]")
        slots = dict(zip(cls.__slots__, cls._slot_types))
        if name not in slots:
            raise IpyrosError(f"the guard's path {path!r}: {cls._type} has no field {name!r}")
        slot_type = slots[name]
        base = slot_type.partition("[")[0]
        expr = f"{expr}.{name}"
        if index:
            if index in ("*", ":"):
                lines.append(f"{'  ' * depth}for (size_t i{depth} = 0; i{depth} < {expr}.size(); ++i{depth}) {{")
                place = f"i{depth}"
                expr = f"{expr}[i{depth}]"
            else:
                lines.append(f"{'  ' * depth}if ({expr}.size() > {int(index)}) {{")
                expr = f"{expr}[{int(index)}]"
            depth += 1
        if number < len(steps) - 1:
            if "/" not in base and base != "Header":
                raise IpyrosError(f"the guard's path {path!r}: {name!r} is a {slot_type}, not a message")
            cls = message_class("std_msgs/Header" if base == "Header" else base)
    lines.append(f"{'  ' * depth}{act(place, expr)}")
    for level in range(depth - 1, -1, -1):
        lines.append(f"{'  ' * level}}}")
    return "\n".join(lines)


def indent(text: str, spaces: int) -> str:
    return "\n".join((" " * spaces + line) if line else line for line in text.splitlines())
