"""Where a thread's printing goes: to the process's own streams, or to a sink that thread has set for a while.

Two things need a thread's text and no other's: ``%try`` keeps what a handler prints while it is
tried (the node's own callbacks print as usual meanwhile), and in Jupyter a node's handlers print
below the cell that made the node. :func:`route` puts one :class:`RoutedStream` in front of
``sys.stdout`` and ``sys.stderr``, once, for as long as the extension is loaded; each of those
then sets a sink for its own thread (:func:`into`, or :func:`enter`/:func:`leave` around a handler
call): nothing swaps a process-wide stream while it runs, and text written by every other thread
goes where it always went.
"""

from __future__ import annotations

import contextlib
import sys
import threading
from typing import Any, Iterator, Optional, Protocol

__all__ = ["RoutedStream", "Sink", "enter", "into", "leave", "route", "routed", "unroute"]


class Sink(Protocol):
    def write(self, text: str) -> int: ...


_local = threading.local()


def enter(sink: Optional[Sink]) -> Optional[Sink]:
    """From now on this thread's text goes to ``sink`` (None: the process's streams); what it went to before."""
    previous = getattr(_local, "sink", None)
    _local.sink = sink
    return previous


def leave(previous: Optional[Sink]) -> None:
    """Back to where this thread's text went before :func:`enter`."""
    _local.sink = previous


@contextlib.contextmanager
def into(sink: Sink) -> Iterator[Sink]:
    """Within the block, what this thread prints goes to ``sink`` (the streams must be :func:`route`-d)."""
    previous = enter(sink)
    try:
        yield sink
    finally:
        leave(previous)


class RoutedStream:
    """Stands for ``sys.stdout`` or ``sys.stderr``: a thread's text to its sink, if it set one; the rest through."""

    def __init__(self, original: Any) -> None:
        self.original = original

    def write(self, text: str) -> int:
        sink = getattr(_local, "sink", None)
        if sink is not None:
            return sink.write(text)
        return self.original.write(text)

    def flush(self) -> None:
        if getattr(_local, "sink", None) is None:
            self.original.flush()

    def isatty(self) -> bool:
        return getattr(_local, "sink", None) is None and self.original.isatty()

    def __getattr__(self, name: str) -> Any:  # fileno, encoding, the kernel's own methods ...
        return getattr(self.original, name)


def route() -> None:
    """Put a :class:`RoutedStream` in front of ``sys.stdout`` and ``sys.stderr`` (once)."""
    for name in ("stdout", "stderr"):
        stream = getattr(sys, name)
        if not isinstance(stream, RoutedStream):
            setattr(sys, name, RoutedStream(stream))


def routed() -> bool:
    """Whether ``sys.stdout`` passes a thread's text to its sink (see :func:`route`)."""
    return isinstance(sys.stdout, RoutedStream)


def unroute() -> None:
    """Take the :class:`RoutedStream` away again, if nothing has replaced it since."""
    for name in ("stdout", "stderr"):
        stream = getattr(sys, name)
        if isinstance(stream, RoutedStream):
            setattr(sys, name, stream.original)
