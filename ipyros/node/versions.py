"""A node's handler versions: every function each of its handler slots was given, and which one serves now.

``nd.versions("/cmd_vel")`` lists them, ``nd.revert("/cmd_vel", 1)`` brings one back, the history
records each with its source, and a saved file restores them. A version is kept as its function while
it lives, and as source text (:mod:`ipyros.core.versions`) for a version read from a file, compiled
when it is chosen.
"""

from __future__ import annotations

import time
from typing import Any, Callable, Optional

from ..core import versions as versions_mod
from ..core.errors import DeclarationError, NotDeclaredError
from ..core.versions import HandlerVersion

__all__ = ["HandlerVersions", "parse_versions"]


class HandlerVersions:
    """The versions of every handler slot of one node (slot key → versions, oldest first)."""

    def __init__(self) -> None:
        self._versions: dict[str, list[HandlerVersion]] = {}
        self._current: dict[str, int] = {}  # slot key → number of the version serving it
        #: The number of the version being brought back, while a revert declares it again.
        self.reverting: Optional[int] = None
        self._pending: Optional[tuple[str, HandlerVersion]] = None  # what the next history record tells

    def given(self, slot: str, handler: Callable[..., Any]) -> None:
        """``slot`` is served by ``handler`` now: a new version, or (while reverting) an old one brought back."""
        found = self._versions.setdefault(slot, [])
        if self.reverting is not None:
            version = found[self.reverting - 1]
        else:
            version = HandlerVersion(len(found) + 1, time.time(), versions_mod.name_of(handler) or "handler",
                                     versions_mod.source_of(handler), handler)
            found.append(version)
        self._current[slot] = version.number
        self._pending = (slot, version)

    def take_pending(self) -> Optional[tuple[str, HandlerVersion]]:
        """The version the last change gave a slot, once (for the history)."""
        pending, self._pending = self._pending, None
        return pending

    def of(self, slot: str) -> tuple[list[HandlerVersion], Optional[int]]:
        """Every function ``slot`` was given, oldest first, and the number of the one serving now."""
        return list(self._versions.get(slot, ())), self._current.get(slot)

    def choose(self, slot: str, number: Any, label: str, advice: str,
               namespace: Callable[[], dict[str, Any]]) -> HandlerVersion:
        """Version ``number`` of ``slot``, its function compiled (in ``namespace()``) if it was kept as source."""
        known = self._versions.get(slot, [])
        if isinstance(number, bool) or not isinstance(number, int) or not 1 <= number <= len(known):
            raise NotDeclaredError(f"{label} has versions 1 to {len(known)}, not {number!r}; {advice} lists them")
        chosen = known[number - 1]
        if chosen.function is None:
            chosen.function = versions_mod.compile_version(chosen, namespace(), label)
        return chosen

    def set(self, slot: str, versions: list[HandlerVersion], current: int) -> None:
        """Give ``slot`` this past (a saved file's), version ``current`` serving."""
        self._versions[slot] = versions
        self._current[slot] = current

    def snapshot(self) -> tuple[dict[str, list[HandlerVersion]], dict[str, int]]:
        return {slot: list(found) for slot, found in self._versions.items()}, dict(self._current)

    def restore(self, snapshot: tuple[dict[str, list[HandlerVersion]], dict[str, int]]) -> None:
        self._versions, self._current = snapshot
        self._pending = None


def parse_versions(what: str, versions: list[tuple[str, str]], current: Optional[int]) -> tuple[
        list[HandlerVersion], int]:
    """``restore_versions``' input checked: the versions as records, and the number of the one serving."""
    current = len(versions) if current is None else current
    if not versions or isinstance(current, bool) or not isinstance(current, int) or not 1 <= current <= len(versions):
        raise DeclarationError(f"restore_versions({what!r}): current={current!r} is not one of the "
                               f"{len(versions)} versions given")
    restored = []
    for number, entry in enumerate(versions, 1):
        if not (isinstance(entry, (tuple, list)) and len(entry) == 2 and isinstance(entry[1], str)
                and entry[1].strip()):
            raise DeclarationError(f"restore_versions({what!r}): version {number} is not (time, source text)")
        when, source = entry
        restored.append(HandlerVersion(number, versions_mod.parse_time(when), versions_mod.defined_name(source),
                                       source))
    return restored, current
