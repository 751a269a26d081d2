"""What an agent asked to change, waiting for the person at the prompt: ``%mcp approve N`` or ``%mcp deny N``.

An agent's server never changes the session itself. A change it proposes (a handler, a revert, one message, one
service call) becomes a :class:`Request`, numbered, told at the prompt once with what it would do; the change
itself is a call kept in the request, made only when the person approves, in the prompt's own thread, and what it
did is the request's answer. A request is answered once: approved, denied, or failed (the change raised, and what it
raised is the answer; nothing was half-made by the approval itself).

Pure: threads may ask, and the agent may read the answers, while the person answers at the prompt.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from typing import Callable

from ..core.errors import IpyrosError

__all__ = ["Request", "Requests", "NoSuchRequest"]


class NoSuchRequest(IpyrosError, LookupError):
    """No request has that number, or it was answered already."""


@dataclass
class Request:
    """One change an agent asked for: ``what`` in a line, ``detail`` the rest (a rehearsal, a diff)."""

    number: int
    kind: str  # "swap", "revert", "publish", "call"
    what: str
    detail: str
    act: Callable[[], str] = field(repr=False)  # makes the change; says what it did
    asked: float = field(default_factory=time.time)
    state: str = "pending"  # then "approved", "denied" or "failed"
    answer: str = ""

    def as_data(self) -> dict[str, object]:
        return {"number": self.number, "kind": self.kind, "what": self.what, "state": self.state,
                "answer": self.answer}

    def notice(self) -> str:
        """What the prompt shows once, as the request arrives."""
        detail = f"\n{self.detail.rstrip()}" if self.detail.strip() else ""
        return (f"ipyros: the agent asks (#{self.number}): {self.what}{detail}\n"
                f"ipyros: %mcp approve {self.number} makes it, %mcp deny {self.number} refuses it")


class Requests:
    """The agent's requests, numbered from 1 for the server's life; ``tell(text)`` shows each one at the prompt."""

    def __init__(self, tell: Callable[[str], None]) -> None:
        self._tell = tell
        self._lock = threading.Lock()
        self._all: dict[int, Request] = {}

    def ask(self, kind: str, what: str, detail: str, act: Callable[[], str]) -> Request:
        """A new pending request, told at the prompt."""
        with self._lock:
            request = Request(len(self._all) + 1, kind, what, detail, act)
            self._all[request.number] = request
        self._tell(request.notice())
        return request

    def pending(self) -> list[Request]:
        with self._lock:
            return [r for r in self._all.values() if r.state == "pending"]

    def get(self, number: int) -> Request:
        with self._lock:
            found = self._all.get(number)
        if found is None:
            raise NoSuchRequest(f"no request #{number} of the agent; %mcp status lists those pending")
        return found

    def approve(self, number: int) -> Request:
        """Make the change of request ``number`` now, in this thread; the request says what happened."""
        request = self._take(number)
        try:
            request.answer = request.act()
            request.state = "approved"
        except Exception as error:  # noqa: BLE001 - the change failed: said, as the request's answer
            request.state, request.answer = "failed", f"{type(error).__name__}: {error}" \
                if not isinstance(error, IpyrosError) else str(error)
        return request

    def deny(self, number: int, why: str = "") -> Request:
        request = self._take(number)
        request.state, request.answer = "denied", why or "the person denied it"
        return request

    def deny_all(self, why: str) -> int:
        """Every pending request denied (the server stops); how many there were."""
        taken = 0
        for request in self.pending():
            try:
                self.deny(request.number, why)
                taken += 1
            except NoSuchRequest:
                pass
        return taken

    def _take(self, number: int) -> Request:
        """Request ``number``, taken out of pending under the lock: two answers cannot both make it."""
        with self._lock:
            request = self._all.get(number)
            if request is None or request.state != "pending":
                state = "no such request" if request is None else f"it was {request.state} already"
                raise NoSuchRequest(f"request #{number} cannot be answered: {state}; %mcp status lists those pending")
            request.state = "answering"
        return request

    def latest(self, count: int = 20) -> list[Request]:
        with self._lock:
            return list(self._all.values())[-count:]
