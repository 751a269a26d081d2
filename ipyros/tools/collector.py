"""Keeping Python's garbage collector from stalling the prompt.

A full collection walks every object the process tracks, and in a session (IPython, rclpy or
rospy, the message types the completion catalog imported) that took 70 to 105 ms each, 18 times
in one run of the completion bench with 10,000 topics: a TAB pressed then waited that long. The
objects that exist once a session is set up live as long as it does, so a :class:`Freezer` moves
them out of the collector's walk with :func:`gc.freeze` (Python's advice for long-lived
processes); a full collection then walks only what came after (9 to 26 ms in the same bench, and
every TAB of it under 6.2 ms p99). :meth:`Freezer.thaw` puts them back.

The price: a reference cycle among the frozen objects is never freed (those that simply fall
out of use are, as always); they are what the session loaded, which it keeps anyway.
"""

from __future__ import annotations

import gc
import threading
import time
from typing import Callable

__all__ = ["Freezer"]


class Freezer:
    """Freezes the process's objects from a background thread once each ``ready(timeout)`` is true (the
    session's warm-up: the catalog scanned, the graph read), or after ``patience`` seconds; :meth:`thaw`
    undoes it, or stops it from happening if it has not yet."""

    def __init__(self, *ready: Callable[[float], bool], patience: float = 60.0) -> None:
        self._cancelled = threading.Event()
        self._lock = threading.Lock()  # freezing and thawing never cross
        self.frozen = False
        self._thread = threading.Thread(target=self._freeze, args=(ready, patience), name="ipyros-gc-freeze",
                                        daemon=True)
        self._thread.start()

    def _freeze(self, ready: tuple[Callable[[float], bool], ...], patience: float) -> None:
        deadline = time.monotonic() + patience
        for done in ready:
            while not done(0.2) and not self._cancelled.is_set() and time.monotonic() < deadline:
                pass
        with self._lock:
            if self._cancelled.is_set():
                return
            gc.collect()  # once, so that what is garbage now is not frozen with the rest
            gc.freeze()
            self.frozen = True

    def thaw(self) -> None:
        """Give the frozen objects back to the collector (at once if the freeze has not happened yet)."""
        with self._lock:
            self._cancelled.set()
            if self.frozen:
                gc.unfreeze()
                self.frozen = False
        self._thread.join(1.0)
