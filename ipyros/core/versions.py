"""The versions of a node's handlers: every function a subscription, timer or service was given.

Each time a handler slot gets a new function (declared, edited with ``%handler``,
restored from a file), the node adds a :class:`HandlerVersion` with its source and
time; going back to one (``nd.revert("cmd_vel", 1)``) makes it current again without
adding a version. A version keeps its function while this interpreter lives; one read
from a saved file has only its source, compiled when it is brought back.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from datetime import datetime
from typing import Any, Callable, Optional

from .code import define_function, handler_source
from .errors import IpyrosError


@dataclass
class HandlerVersion:
    """One function a handler slot was given."""

    number: int
    time: float
    name: str
    source: Optional[str]  # None: not findable (built by exec, a builtin, ...)
    function: Optional[Callable[..., Any]] = field(default=None, repr=False, compare=False)

    @property
    def when(self) -> str:
        return datetime.fromtimestamp(self.time).isoformat(sep=" ", timespec="seconds")


def source_of(fn: Any) -> Optional[str]:
    """``fn``'s source as a saved file keeps it, or None where there is none."""
    try:
        return handler_source(fn, "version")
    except IpyrosError:
        return None


def parse_time(text: str) -> float:
    """A version's time as saved (``2026-11-21 10:02:03``), as seconds since the epoch."""
    try:
        return datetime.fromisoformat(text).timestamp()
    except (TypeError, ValueError):
        raise IpyrosError(f"version time {text!r} is not a date and time like '2026-11-21 10:02:03'") from None


def compile_version(version: HandlerVersion, namespace: dict, label: str) -> Callable[..., Any]:
    """The function of ``version``, defined from its source in ``namespace`` (its globals)."""
    if version.source is None:
        raise IpyrosError(f"version {version.number} of {label} ({version.name}) has no source to run again")
    return define_function(version.name, version.source, namespace, f"version {version.number} of {label}")


def defined_name(source: str) -> str:
    """The name a handler's source defines: ``def name(...)``, else ``<lambda>``."""
    match = re.match(r"\s*(?:async\s+)?def\s+(\w+)", source)
    return match.group(1) if match else "<lambda>"


def name_of(handler: Any) -> Optional[str]:
    """A handler's name as the model keeps it (None for no handler)."""
    return None if handler is None else getattr(handler, "__name__", type(handler).__name__)
