"""Progress on long work, said where a person watches: what is done, the rate, the time left.

Work that takes more than a second (``%try --bag`` over 100,000 messages, ``%bag convert`` of a large bag) takes a
``progress`` from whoever runs it: ``with progress("trying /scan", total=100_000, unit="messages") as step:`` and
``step(done)`` now and then (cheap: a view redraws a few times a second at most). What draws it is the front end's
(the IPython extension gives a terminal a rich bar and Jupyter an updating line; a plain script gets
:func:`no_progress`, which draws nothing), so the work itself knows nothing of terminals. A view is gone when the
work ends, and Ctrl-C ends the work as it would without one.
"""

from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass
from typing import Callable, ContextManager, Iterator, Optional, Protocol

__all__ = ["Progress", "Step", "Tally", "no_progress"]

#: ``step(done)``: how much of the work is done so far (in the work's unit).
Step = Callable[[float], None]


class Progress(Protocol):
    """``progress(what, total, unit)``: a context giving the work its :data:`Step`; ``total`` None when unknown."""

    def __call__(self, what: str, total: Optional[float] = None, unit: str = "") -> ContextManager[Step]: ...


@contextlib.contextmanager
def no_progress(what: str, total: Optional[float] = None, unit: str = "") -> Iterator[Step]:
    """Draws nothing: where nobody watches (a script, output that is not a terminal)."""
    yield lambda done: None


@dataclass
class Tally:
    """What a view says: done of total, the rate since the start, the time left at that rate."""

    what: str
    total: Optional[float]
    unit: str = ""
    done: float = 0.0
    started: float = 0.0

    def __post_init__(self) -> None:
        self.started = self.started or time.monotonic()

    def line(self, now: Optional[float] = None) -> str:
        """``trying /scan: 45,000 of 100,000 messages, 30,000/s, 2 s left`` (what is known of it)."""
        elapsed = max(1e-9, (now or time.monotonic()) - self.started)
        unit = f" {self.unit}" if self.unit else ""
        rate = self.done / elapsed
        if self.total:
            left = (self.total - self.done) / rate if rate > 0 else None
            said = f"{self.done:,.0f} of {self.total:,.0f}{unit}"
            tail = f", {_seconds(left)} left" if left is not None else ""
        else:
            said, tail = f"{self.done:,.0f}{unit}", ""
        speed = f", {rate:,.0f}/s" if self.done and self.unit != "s" else ""  # time goes at 1 s a second
        return f"{self.what}: {said}{speed}{tail}" if self.done or self.total else f"{self.what}: {_seconds(elapsed)}"


def _seconds(value: float) -> str:
    if value < 60:
        return f"{value:.0f} s"
    return f"{value // 60:.0f} min {value % 60:.0f} s"
