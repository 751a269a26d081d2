"""Message and service types: from a class or a "pkg/Type" string to the generated class.

Unknown types get an error naming what was not found, with the closest known names,
found by scanning the Python message packages on ``sys.path`` (no rospy needed).
"""

from __future__ import annotations

import difflib
import importlib
import importlib.util
import os
import re
import sys
from functools import lru_cache
from pathlib import Path
from typing import Any, Iterable

from .errors import MessageTypeError


def type_name(cls: Any) -> str | None:
    """The ROS type name ``"pkg/Type"`` of a generated message or service class (or instance), else None.

    ROS 1 classes say it (``_type``); ROS 2 classes live in ``pkg.msg._snake_name`` (or
    ``.srv``, or ``.action`` for an action's parts: ``test_msgs/Fibonacci_Goal``) and are
    recognised by their metaclass's ``_TYPE_SUPPORT``. Both are named
    ``"pkg/Type"`` in the model, so a node saved on one ROS reads the same on the other.
    """
    name = getattr(cls, "_type", None)
    if isinstance(name, str) and "/" in name:
        return name
    cls = cls if isinstance(cls, type) else type(cls)
    parts = getattr(cls, "__module__", "").split(".")
    if len(parts) == 3 and parts[1] in ("msg", "srv", "action") and hasattr(type(cls), "_TYPE_SUPPORT"):
        return f"{parts[0]}/{cls.__name__}"
    return None


def short_name(type_name: str) -> str:
    """``std_msgs/msg/String`` → ``std_msgs/String``: the one spelling a session shows on both ROS (ROS 2's
    ``pkg/msg/Type``, ``pkg/srv/Type`` and ``pkg/action/Type`` are read as input too)."""
    parts = type_name.split("/")
    return f"{parts[0]}/{parts[-1]}" if len(parts) == 3 else type_name


def another_type_line(topic: str, peers: str, theirs: str, declared: str, ros: str) -> str:
    """What a subscription of ``topic`` as ``declared`` is told of ``peers`` ("a publisher" when unnamed) that
    publish it as ``theirs``, on either ROS (``ros``: "ROS", "ROS 2"): nothing passes, and what to do."""
    return (f"{topic}: {peers} publishes {theirs} there, and this node subscribes to it as {declared}: nothing "
            f"passes between them ({ros} connects no two types); subscribe with msgType={theirs!r}, or publish "
            f"{declared}")


def is_service(cls: type) -> bool:
    """A service class: ROS 1's have ``_request_class``, ROS 2's ``Request``."""
    return hasattr(cls, "_request_class") or (hasattr(cls, "Request") and hasattr(cls, "Response"))


def is_action(cls: Any) -> bool:
    """An action class: ROS 2's has ``Goal``, ``Result``, ``Feedback`` and ``Impl``; ROS 1's ``XAction``
    message has the slots ``action_goal``, ``action_result``, ``action_feedback``."""
    if not isinstance(cls, type):
        return False
    ros2 = all(hasattr(cls, part) for part in ("Goal", "Result", "Feedback", "Impl"))
    return ros2 or "action_goal" in getattr(cls, "__slots__", ())


def action_type_name(cls: type) -> str:
    """``"pkg/Type"`` of an action class: ``test_msgs/Fibonacci``, ``actionlib/TwoInts`` (not ``TwoIntsAction``)."""
    ros1 = getattr(cls, "_type", None)
    if isinstance(ros1, str):
        return ros1.removesuffix("Action")
    return f"{cls.__module__.split('.')[0]}/{cls.__name__}"


def action_messages(cls: Any) -> tuple[type, type, type]:
    """The Goal, Result and Feedback message classes of an action class of either ROS."""
    if hasattr(cls, "Goal"):  # ROS 2: nested in the action class
        return cls.Goal, cls.Result, cls.Feedback
    module = importlib.import_module(cls.__module__.split(".")[0] + ".msg")  # ROS 1: XGoal beside XAction
    stem = cls.__name__.removesuffix("Action")
    return getattr(module, stem + "Goal"), getattr(module, stem + "Result"), getattr(module, stem + "Feedback")


def resolve_action(spec: Any) -> tuple[str, type]:
    """Return ``(type_name, class)`` for an action class or a ``"pkg/Type"`` string.

    The class is ROS 2's action class (``test_msgs.action.Fibonacci``) or ROS 1's
    ``XAction`` message (``actionlib.msg.TwoIntsAction``): whichever this Python has.
    ``pkg/action/Type`` (ROS 2's spelling) and ``pkg/TypeAction`` (ROS 1's) are read too.
    """
    if spec is None:
        raise MessageTypeError("no action type given; pass type=... e.g. 'actionlib/TwoInts' or "
                               "'test_msgs/Fibonacci'")
    if isinstance(spec, type):
        if not is_action(spec):
            raise MessageTypeError(f"{spec.__name__} is not a ROS action class; pass a generated action such as "
                                   "test_msgs.action.Fibonacci (ROS 2) or actionlib.msg.TwoIntsAction (ROS 1)")
        return action_type_name(spec), spec
    if not isinstance(spec, str):
        raise MessageTypeError(f"action type must be a class or a 'pkg/Type' string, not {type(spec).__name__}")
    parts = spec.strip().split("/")
    if len(parts) == 3 and parts[1] == "action":
        parts = [parts[0], parts[2]]
    if len(parts) != 2 or not all(p.isidentifier() for p in parts):
        raise MessageTypeError(f"malformed action type {spec!r}: write 'package/Type', e.g. 'test_msgs/Fibonacci'")
    package, name = parts[0], parts[1].removesuffix("Action") or parts[1]
    for module_name, attribute in ((f"{package}.action", name), (f"{package}.msg", name + "Action")):
        try:
            cls = getattr(importlib.import_module(module_name), attribute, None)
        except ImportError:
            continue
        if cls is not None and is_action(cls):
            return f"{package}/{name}", cls
    close = difflib.get_close_matches(f"{package}/{name}", known_action_types(), n=3)
    hint = f"; did you mean {', '.join(close)}?" if close else \
        f"; is it installed here? ({install_hint(package)})"
    raise MessageTypeError(f"unknown action type {spec!r}{hint}")


def known_action_types() -> list[str]:
    """Every action type whose Python classes are importable here, as "pkg/Type", sorted."""
    ros2 = [f"{p}/{t}" for p, types in _index("action").items() for t in types if "_" not in t]
    ros1 = [f"{p}/{t[:-6]}" for p, types in _index("msg").items() for t in types
            if t.endswith("Action") and t + "Goal" in types]
    return sorted(set(ros2 + ros1))


def resolve_message(spec: Any) -> tuple[str, type]:
    """Return ``(type_name, class)`` for a message class or a ``"pkg/Type"`` string."""
    return _resolve(spec, "msg")


def message_class_or_none(type_name: str) -> Any:
    """The message class of ``type_name``, or None if this Python cannot import it (a check of a path into its
    messages is then left to the messages themselves)."""
    try:
        return resolve_message(type_name)[1]
    except MessageTypeError:
        return None


def resolve_service(spec: Any) -> tuple[str, type]:
    """Return ``(type_name, class)`` for a service class or a ``"pkg/Type"`` string."""
    return _resolve(spec, "srv")


def _resolve(spec: Any, kind: str) -> tuple[str, type]:
    what = "message" if kind == "msg" else "service"
    if spec is None:
        raise MessageTypeError(f"no {what} type given; pass msgType=... e.g. Twist or 'geometry_msgs/Twist'")
    if isinstance(spec, type):
        name = type_name(spec)
        if name is None or is_service(spec) != (kind == "srv") or is_action(spec):
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
        hint = f"; it is not installed here ({install_hint(package)})"
        if close:
            hint += f", or did you mean {', '.join(close)}?"
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
        for init in root.glob(f"*/{kind}/__init__.py"):
            names = _type_names(init)
            if names:
                found.setdefault(init.parent.parent.name, set()).update(names)
    return {pkg: tuple(sorted(types)) for pkg, types in sorted(found.items())}


_EXPORTED = re.compile(r"^from \S+\._\w+ import (\w+)", re.M)  # ROS 2: from pkg.msg._twist import Twist


def forget_index() -> None:
    """Read the installed message packages again next time (a package was just built or installed)."""
    _index.cache_clear()


# -- a workspace's own message packages, built at the prompt (each ROS's msggen) -------------

def messages_dir(into: "str | os.PathLike[str] | None" = None) -> Path:
    """Where built message packages go: ``into``, else ``$IPYROS_MESSAGES_DIR``, else ``~/.ipyros/messages``."""
    return Path(into or os.environ.get("IPYROS_MESSAGES_DIR") or Path.home() / ".ipyros" / "messages").expanduser()


def package_name_of(package_dir: Path) -> str:
    """A message package's name: its package.xml's ``<name>``, else its folder's."""
    manifest = package_dir / "package.xml"
    if manifest.is_file():
        found = re.search(r"<name>\s*([A-Za-z][\w]*)\s*</name>", manifest.read_text(errors="replace"))
        if found:
            return found.group(1)
    return package_dir.name


def import_from(root: Path) -> None:
    """Make the packages under ``root`` importable here and in the processes started from here."""
    path = str(root)
    if path not in sys.path:
        sys.path.insert(0, path)
    parts = [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p and p != path]
    os.environ["PYTHONPATH"] = os.pathsep.join([path, *parts])
    forget_index()
    importlib.invalidate_caches()


def _type_names(init: Path) -> set[str]:
    """The types a generated ``pkg/msg/__init__.py`` exports (ROS 1: one ``_Type.py`` module each)."""
    names = {m.stem[1:] for m in init.parent.glob("_*.py") if m.name != "__init__.py" and m.stem[1:2].isupper()}
    if names:
        return names
    try:
        return {name for name in _EXPORTED.findall(init.read_text(errors="replace")) if name[:1].isupper()}
    except OSError:
        return set()


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


def not_installed(type_names: Iterable[str]) -> dict[str, str]:
    """``{type: how to install it}`` for each message type of ``type_names`` this Python cannot import (a
    workspace's own type, a package the venv lacks); the graph still lists such topics."""
    missing = {}
    for name in sorted(set(filter(None, type_names))):
        try:
            resolve_message(name)
        except MessageTypeError:
            missing[name] = install_hint(name.split("/", 1)[0])
    return missing


def install_hint(package: str) -> str:
    """How to install the Python messages of ROS package ``package`` where this Python gets its ROS.

    ROS 2 from PyPI (a venv's rclpy): the wheel ``ros-<name>`` (``ros-jazzy-<name>`` for Jazzy's);
    ROS 2 from apt (``/opt/ros/<distro>``): ``ros-<distro>-<name>``; ROS 1 from Debian: ``python3-<name>``.
    """
    dashed = package.replace("_", "-")
    rclpy = importlib.util.find_spec("rclpy")
    if rclpy is not None and rclpy.origin and not rclpy.origin.startswith("/opt/ros/"):
        from importlib import metadata

        try:
            metadata.version("ros-jazzy-rclpy")
            return f"pip install ros-jazzy-{dashed}"
        except metadata.PackageNotFoundError:
            return f"pip install ros-{dashed}"
    if rclpy is not None:
        distro = os.environ.get("ROS_DISTRO") or (rclpy.origin or "").split("/")[3]
        return f"apt install ros-{distro}-{dashed}"
    return f"apt install python3-{dashed}"
