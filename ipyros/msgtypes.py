"""Message and service types: from a class or a "pkg/Type" string to the generated class.

Unknown types get an error naming what was not found, with the closest known names,
found by scanning the Python message packages on ``sys.path`` (no rospy needed).
"""

from __future__ import annotations

import difflib
import importlib
import sys
from functools import lru_cache
from pathlib import Path
from typing import Any

from .errors import MessageTypeError


def type_name(cls: Any) -> str | None:
    """The ROS type name of a generated message class (or instance), else None."""
    name = getattr(cls, "_type", None)
    return name if isinstance(name, str) and "/" in name else None


def resolve_message(spec: Any) -> tuple[str, type]:
    """Return ``(type_name, class)`` for a message class or a ``"pkg/Type"`` string."""
    return _resolve(spec, "msg")


def resolve_service(spec: Any) -> tuple[str, type]:
    """Return ``(type_name, class)`` for a service class or a ``"pkg/Type"`` string."""
    return _resolve(spec, "srv")


def _resolve(spec: Any, kind: str) -> tuple[str, type]:
    what = "message" if kind == "msg" else "service"
    if spec is None:
        raise MessageTypeError(f"no {what} type given; pass msgType=... e.g. Twist or 'geometry_msgs/Twist'")
    if isinstance(spec, type):
        name = type_name(spec)
        is_service = hasattr(spec, "_request_class")
        if name is None or is_service != (kind == "srv"):
            raise MessageTypeError(
                f"{spec.__name__} is not a ROS {what} class; pass a generated type such as "
                + ("geometry_msgs.msg.Twist" if kind == "msg" else "std_srvs.srv.Empty")
            )
        return name, spec
    if not isinstance(spec, str):
        raise MessageTypeError(f"{what} type must be a class or a 'pkg/Type' string, not {type(spec).__name__}")
    parts = spec.strip().split("/")
    if len(parts) == 3 and parts[1] == kind:  # "pkg/msg/Type" is also how ROS 2 spells it
        parts = [parts[0], parts[2]]
    if len(parts) != 2 or not all(p.isidentifier() for p in parts):
        hint = _hint(spec.split("/")[-1], kind)
        raise MessageTypeError(f"malformed {what} type {spec!r}: write 'package/Type'{hint}")
    package, name = parts
    other = "srv" if kind == "msg" else "msg"
    if name not in _index(kind).get(package, ()) and name in _index(other).get(package, ()):
        # "std_srvs/Empty" where a message is wanted: say so, not "did you mean std_msgs".
        use = ("a topic needs a message type such as 'std_msgs/Empty'" if kind == "msg"
               else "a service needs a service type such as 'std_srvs/Empty'")
        raise MessageTypeError(f"{spec!r} is a {'service' if other == 'srv' else 'message'} type, "
                               f"not a {what} type; {use}")
    try:
        module = importlib.import_module(f"{package}.{kind}")
    except ImportError:
        close = difflib.get_close_matches(package, _packages(kind), n=3)
        hint = f"; did you mean {', '.join(close)}?" if close else f" (is python3-{package.replace('_', '-')} installed?)"
        raise MessageTypeError(f"unknown {what} package {package!r} in {spec!r}{hint}") from None
    cls = getattr(module, name, None)
    if not isinstance(cls, type) or type_name(cls) != f"{package}/{name}":
        close = difflib.get_close_matches(name, _types_in(package, kind), n=3)
        hint = f"; did you mean {', '.join(f'{package}/{c}' for c in close)}?" if close else ""
        raise MessageTypeError(f"unknown {what} type {spec!r}: package {package!r} has no {name!r}{hint}")
    return f"{package}/{name}", cls


def _hint(name: str, kind: str) -> str:
    known = known_message_types() if kind == "msg" else known_service_types()
    by_short = {t.split("/")[1]: t for t in known}
    close = difflib.get_close_matches(name, list(by_short), n=3)
    return f"; did you mean {', '.join(by_short[c] for c in close)}?" if close else ""


@lru_cache(maxsize=None)
def _index(kind: str) -> dict[str, tuple[str, ...]]:
    """{package: (Type, ...)} for every generated Python message/service module on sys.path."""
    found: dict[str, set[str]] = {}
    for entry in sys.path:
        root = Path(entry or ".")
        if not root.is_dir():
            continue
        for module in root.glob(f"*/{kind}/_*.py"):
            if module.name != "__init__.py":
                found.setdefault(module.parent.parent.name, set()).add(module.stem[1:])
    return {pkg: tuple(sorted(types)) for pkg, types in sorted(found.items())}


def _packages(kind: str) -> list[str]:
    return list(_index(kind))


def _types_in(package: str, kind: str) -> list[str]:
    return list(_index(kind).get(package, ()))


def known_message_types() -> list[str]:
    """Every message type whose Python class is importable here, as "pkg/Type", sorted."""
    return [f"{p}/{t}" for p, types in _index("msg").items() for t in types]


def known_service_types() -> list[str]:
    """Every service type whose Python class is importable here, as "pkg/Type", sorted."""
    return [f"{p}/{t}" for p, types in _index("srv").items() for t in types]
