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
from typing import Any, Callable, Optional

from ..core.errors import MasterError
from ..core import plan as planning
from ..core.graph import EMPTY, GraphSnapshot, frozen

__all__ = ["REST", "GraphCache", "as_dsl_nodes", "live_graph"]

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


def live_graph(backend: Any, graph: GraphCache) -> GraphSnapshot:
    """The graph read afresh through ``graph`` (a master that just restarted gets the session registered again
    first); a one-line error when no master answers. What the magics and an agent's tools both read."""
    backend.check_graph()
    snap = graph.refresh_now()
    if not snap.master_up:
        raise MasterError(f"no ROS master answers at {graph.where}; start roscore, "
                          "or check ROS_MASTER_URI (c.RosMagics.master_uri)")
    return snap


def as_dsl_nodes(snap: GraphSnapshot, session: Any) -> GraphSnapshot:
    """``snap`` with this session's ROS 1 node replaced, topic by topic, by its DSL nodes that use the topic.

    On ROS 1 every DSL node of the session lives in one ROS node, named after the first
    one created: after ``nd.shutdown()`` the master still lists that name as publishing
    what the session's other nodes (a ``%pub``) publish. Naming the DSL nodes says who.
    """
    process = session.process.name if session.process.shared else None
    if not process:
        return snap
    uses: dict[tuple[str, str], list[str]] = {}
    for node in list(session.nodes.values()):
        for spec in planning.plan(node.model()):
            if isinstance(spec, planning.PublishSpec):
                ends = [(spec.topic, "publish")]
            elif isinstance(spec, planning.SubscribeSpec):
                ends = [(spec.topic, "subscribe")]
            elif isinstance(spec, planning.RelaySpec) and spec.machine is None:  # a placed one runs on its machine
                ends = [(spec.source, "subscribe"), (spec.target, "publish")]
            else:  # timers and services: no topic
                ends = []
            for end in ends:
                uses.setdefault(end, []).append(node.fullname)

    def named(mapping: Any, side: str) -> dict[str, tuple[str, ...]]:
        return {topic: tuple(sorted({n for node in nodes for n in (uses.get((topic, side)) or [node]
                                                                    if node == process else [node])}))
                for topic, nodes in mapping.items()}

    return dataclasses.replace(snap, publishers=frozen(named(snap.publishers, "publish")),
                               subscribers=frozen(named(snap.subscribers, "subscribe")))
