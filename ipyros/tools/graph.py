"""A cached, never-blocking view of the live ROS graph, refreshed in the background.

Completion and ``%topics`` want to know which topics, types, nodes and services exist,
and they must answer in milliseconds even when the graph is slow to read, far or gone. So
it is read in the background: a daemon thread asks the session's backend every ``period``
seconds (ROS 1: one XML-RPC round trip to the master; ROS 2: what discovery found) and
swaps in a new immutable :class:`~ipyros.core.graph.GraphSnapshot`. Readers just take the
latest snapshot: an attribute read, no lock, no network.

    >>> graph = GraphCache(backend.graph_snapshot, backend.where, period=1.0).start()
    >>> graph.wait_first(2.0)
    True
    >>> graph.snapshot.topics_matching("/turtle*", type="geometry_msgs/Twist")
    ['/turtle1/cmd_vel']
    >>> graph.stop()
"""

from __future__ import annotations

import dataclasses
import logging
import threading
import time
from typing import Callable, Optional

from ..core.graph import EMPTY, GraphSnapshot

__all__ = ["REST", "GraphCache"]

log = logging.getLogger(__name__)


#: How many times as long as a refresh took the refresh thread waits before the next one (at least ``period``).
REST = 5.0


class GraphCache:
    """Keeps :attr:`snapshot` fresh from a background thread; reading it never blocks.

    ``period`` is the time between refreshes, or more on a large graph: the thread rests
    :data:`REST` times as long as its last refresh took (:attr:`refresh_seconds`), so that
    refreshing takes at most a sixth of a core (ROS 1 with 10,000 topics: about 0.4 s a
    refresh, most of it Python work that would otherwise compete with the prompt's).
    ``timeout`` bounds each master call, so :meth:`stop` returns within about ``timeout``
    seconds even if the master hangs.
    Usable as a context manager (``with GraphCache(source, where) as graph: ...``).
    """

    def __init__(self, source: Callable[[float], GraphSnapshot], where: Callable[[], str], period: float = 1.0,
                 timeout: float = 1.0):
        #: ``source(timeout)`` reads the graph (the backend's ``graph_snapshot``); ``where()`` names it.
        self.source = source
        self._where = where
        self.period = period
        self.timeout = timeout
        self._snapshot: GraphSnapshot = EMPTY
        self._lock = threading.Lock()  # orders snapshot swaps, never held by readers
        self._stop = threading.Event()
        self._first = threading.Event()
        self._thread: Optional[threading.Thread] = None
        #: How long the last background refresh took (s): what a refresh of this graph costs.
        self.refresh_seconds = 0.0

    # -- reading ---------------------------------------------------------------
    @property
    def where(self) -> str:
        """Which graph this is, for titles: the master's URI, or ROS 2's domain."""
        return self._where()

    def _fetch(self, timeout: float) -> GraphSnapshot:
        try:
            return self.source(timeout)  # a master down is a snapshot too (master_up False)
        except Exception:  # noqa: BLE001 - the refresh thread must outlive any one bad read
            log.debug("reading the graph failed; keeping the last snapshot", exc_info=True)
            return self._snapshot

    @property
    def snapshot(self) -> GraphSnapshot:
        """The latest snapshot (empty before the first refresh); never touches the network."""
        return self._snapshot

    def topics_matching(self, pattern: str = "", type: Optional[str] = None, node: Optional[str] = None) -> list[str]:
        """:meth:`GraphSnapshot.topics_matching` on the latest snapshot."""
        return self._snapshot.topics_matching(pattern, type=type, node=node)

    # -- refreshing ------------------------------------------------------------
    def refresh_now(self, timeout: Optional[float] = None) -> GraphSnapshot:
        """Read the master in the calling thread (at most ``timeout`` s of silence) and publish it.

        For magics that must show the graph as it is now rather than up to ``period`` old.
        """
        return self._publish(self._fetch(self.timeout if timeout is None else timeout))

    def _publish(self, snap: GraphSnapshot) -> GraphSnapshot:
        with self._lock:
            # A slow background fetch must not overwrite a newer refresh_now() result.
            if snap.taken_at >= self._snapshot.taken_at:
                last = self._snapshot
                if not snap.master_up and (last.master_up or last.stale):
                    # The master went away: completion keeps offering the last graph, marked stale.
                    snap = dataclasses.replace(last, taken_at=snap.taken_at, master_up=False, stale=True,
                                               known_at=last.known_at if last.stale else last.taken_at)
                self._snapshot = snap
            self._first.set()
            return self._snapshot

    def wait_first(self, timeout: float) -> bool:
        """Wait until the first refresh has finished (master up or not); False on timeout."""
        return self._first.wait(timeout)

    # -- lifecycle -------------------------------------------------------------
    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def start(self) -> "GraphCache":
        """Start the refresh thread (no-op if it runs); returns self for chaining."""
        if not self.running:
            self._stop.clear()
            self._thread = threading.Thread(target=self._loop, name="ipyros-graph", daemon=True)
            self._thread.start()
        return self

    def stop(self) -> None:
        """Stop the refresh thread and wait for it; the last snapshot stays readable."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None

    def _loop(self) -> None:
        while not self._stop.is_set():
            started = time.monotonic()
            self._publish(self._fetch(self.timeout))
            self.refresh_seconds = time.monotonic() - started
            self._stop.wait(max(self.period, REST * self.refresh_seconds))

    def __enter__(self) -> "GraphCache":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    def __repr__(self) -> str:
        snap = self._snapshot
        state = "up" if snap.master_up else "down"
        return f"<GraphCache {self.where} master {state}, {len(snap.topics)} topics, {'running' if self.running else 'stopped'}>"
