"""A cached, never-blocking view of the live ROS graph, read straight from the master.

Completion and ``%topics`` want to know which topics, types, nodes and services exist,
and they must answer in milliseconds even when the master is slow, far or gone. So the
graph is read in the background: a daemon thread asks the master every ``period``
seconds (one XML-RPC round trip: ``getSystemState`` and ``getTopicTypes`` batched in a
``system.multicall``) and swaps in a new immutable :class:`GraphSnapshot`. Readers just
take the latest snapshot: an attribute read, no lock, no network.

Why plain XML-RPC and not rospy: the master API is a documented XML-RPC interface
(the same one ``rosgraph.Master`` wraps), reading it needs no ROS node, and rospy allows
only one node per process, which belongs to the ipyros runtime. ``rosgraph.Master``
itself has no socket timeout, so a master that stops answering would freeze the thread
forever; here every call has a short timeout through a custom transport.

    >>> graph = GraphCache("http://127.0.0.1:11311/", period=1.0).start()
    >>> graph.wait_first(2.0)
    True
    >>> graph.snapshot.topics_matching("/turtle*", type="geometry_msgs/Twist")
    ['/turtle1/cmd_vel']
    >>> graph.stop()
"""

from __future__ import annotations

import bisect
import dataclasses
import fnmatch
import http.client
import logging
import threading
import time
import xmlrpc.client
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Callable, Iterable, Mapping, Optional, Sequence
from xml.parsers.expat import ExpatError

from ..ros1.master import master_proxy

log = logging.getLogger(__name__)

#: The caller id the master sees in its logs for our read-only queries.
CALLER_ID = "/ipyros_graph"

#: Everything a broken, absent or misbehaving master can make an XML-RPC call raise.
_NETWORK_ERRORS = (OSError, xmlrpc.client.Error, http.client.HTTPException, ExpatError, ValueError, TypeError)


def frozen(mapping: dict) -> Mapping:
    """A read-only view of ``mapping`` with its keys in sorted order."""
    return MappingProxyType({k: mapping[k] for k in sorted(mapping)})


@dataclass(frozen=True)
class GraphSnapshot:
    """The ROS graph as the master described it at ``taken_at`` (``time.time()``).

    All mappings are read-only and sorted by key; node lists are sorted tuples.
    ``topics`` holds every topic somebody publishes or subscribes to, with its type
    (``""`` when the master does not know it yet). With the master down ``master_up`` is
    False, and everything is empty unless :class:`GraphCache` kept the last graph (``stale``).
    """

    topics: Mapping[str, str] = field(default_factory=lambda: MappingProxyType({}))
    publishers: Mapping[str, tuple[str, ...]] = field(default_factory=lambda: MappingProxyType({}))
    subscribers: Mapping[str, tuple[str, ...]] = field(default_factory=lambda: MappingProxyType({}))
    services: Mapping[str, tuple[str, ...]] = field(default_factory=lambda: MappingProxyType({}))
    nodes: tuple[str, ...] = ()
    taken_at: float = 0.0
    master_up: bool = False
    #: The master is down and this is the last graph it described (``known_at``): still good to
    #: complete names from, not to act on.
    stale: bool = False
    known_at: float = 0.0
    #: ``topics``' keys as a sorted tuple: prefix searches bisect it (1,000 topics or 100,000).
    topic_names: tuple[str, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "topic_names", tuple(sorted(self.topics)))

    # -- queries --------------------------------------------------------------
    def topics_with_prefix(self, prefix: str) -> list[str]:
        """Topic names starting with ``prefix``, sorted; O(log n + matches)."""
        return names_with_prefix(self.topic_names, prefix)

    def nodes_with_prefix(self, prefix: str) -> list[str]:
        """Node names starting with ``prefix``, sorted."""
        return names_with_prefix(self.nodes, prefix)

    def topics_matching(self, pattern: str = "", type: Optional[str] = None, node: Optional[str] = None) -> list[str]:
        """Topic names that match all the filters given, sorted.

        ``pattern`` is a glob (``/turtle*/pose``) when it has ``*?[``, else a substring
        (``"cmd"`` finds ``/turtle1/cmd_vel``); empty matches everything. ``type`` is an
        exact type name or a glob (``geometry_msgs/*``). ``node`` keeps the topics that
        node publishes or subscribes to.
        """
        names: Iterable[str] = self.topic_names
        if pattern:
            names = (n for n in names if name_matches(n, pattern))
        if type:
            names = (n for n in names if _matches_exactly(self.topics[n], type))
        if node:
            names = (n for n in names if node in self.publishers.get(n, ()) or node in self.subscribers.get(n, ()))
        return list(names)


def names_with_prefix(sorted_names: Sequence[str], prefix: str) -> list[str]:
    """The names in ``sorted_names`` (sorted!) that start with ``prefix``; a bisection, not a scan."""
    start = bisect.bisect_left(sorted_names, prefix)
    # Every string with the prefix sorts before prefix + the largest code point.
    end = bisect.bisect_left(sorted_names, prefix + "\U0010ffff", start)
    return list(sorted_names[start:end])


def _is_glob(pattern: str) -> bool:
    return any(c in pattern for c in "*?[")


def name_matches(name: str, pattern: str) -> bool:
    """``pattern`` as ``%topics`` reads it: a glob when it has ``*?[``, else a substring; empty matches all."""
    return fnmatch.fnmatchcase(name, pattern) if _is_glob(pattern) else pattern in name


def _matches_exactly(name: str, pattern: str) -> bool:
    """A type matches its name or glob; a ROS 2 type (``pkg/msg/Type``) matches ``pkg/Type`` too."""
    if _is_glob(pattern):
        return fnmatch.fnmatchcase(name, pattern) or fnmatch.fnmatchcase(name.replace("/msg/", "/"), pattern)
    return name == pattern or name.replace("/msg/", "/") == pattern.replace("/msg/", "/")


EMPTY = GraphSnapshot()


def fetch_snapshot(master_uri: str, timeout: float = 1.0) -> GraphSnapshot:
    """Ask the master for the whole graph now; an empty snapshot if it cannot answer.

    One HTTP request (a multicall), bounded by ``timeout`` seconds of socket silence.
    Never raises for network trouble: a master that is down, refuses, times out or
    answers garbage all give ``master_up=False``.
    """
    proxy = master_proxy(master_uri, timeout)
    calls = xmlrpc.client.MultiCall(proxy)
    calls.getSystemState(CALLER_ID)
    calls.getTopicTypes(CALLER_ID)
    try:
        (code, _, state), (tcode, _, types) = tuple(calls())
        if code != 1 or tcode != 1:
            return GraphSnapshot(taken_at=time.time())
        return _build(state, dict(types))
    except _NETWORK_ERRORS:
        return GraphSnapshot(taken_at=time.time())
    finally:
        proxy("close")()


def _build(state: list, types: dict[str, str]) -> GraphSnapshot:
    """Turn the master's ``[[topic, [node...]]...]`` triple into a snapshot."""
    pubs, subs, srvs = ({name: tuple(sorted(nodes)) for name, nodes in part} for part in state)
    # The master never forgets a type (getTopicTypes keeps stale topics), so the live
    # topics are those with a publisher or subscriber now; types only annotate them.
    topics = {name: types.get(name, "") for name in (*pubs, *subs)}
    nodes = {n for part in (pubs, subs, srvs) for ns in part.values() for n in ns}
    return GraphSnapshot(
        topics=frozen(topics),
        publishers=frozen(pubs),
        subscribers=frozen(subs),
        services=frozen(srvs),
        nodes=tuple(sorted(nodes)),
        taken_at=time.time(),
        master_up=True,
    )


class GraphCache:
    """Keeps :attr:`snapshot` fresh from a background thread; reading it never blocks.

    ``period`` is the time between refreshes; ``timeout`` bounds each master call, so
    :meth:`stop` returns within about ``timeout`` seconds even if the master hangs.
    Usable as a context manager (``with GraphCache(uri) as graph: ...``).
    """

    def __init__(self, master_uri: str, period: float = 1.0, timeout: float = 1.0,
                 source: Optional[Callable[[], GraphSnapshot]] = None, where: str = ""):
        self.master_uri = master_uri
        self.period = period
        self.timeout = timeout
        #: Where the snapshots come from when not from a ROS 1 master: ROS 2's discovery
        #: (:func:`ipyros.ros2.graph.snapshot`); ``where`` names it in titles.
        self.source = source
        self._where = where
        self._snapshot: GraphSnapshot = EMPTY
        self._lock = threading.Lock()  # orders snapshot swaps, never held by readers
        self._stop = threading.Event()
        self._first = threading.Event()
        self._thread: Optional[threading.Thread] = None

    # -- reading ---------------------------------------------------------------
    @property
    def where(self) -> str:
        """Which graph this is, for titles: the master's URI, or ROS 2's domain."""
        return self._where or self.master_uri

    def use(self, source: Callable[[], GraphSnapshot], where: str) -> None:
        """Read snapshots from ``source`` from now on (ROS 2), not from a master."""
        self.source, self._where = source, where

    def _fetch(self, timeout: float) -> GraphSnapshot:
        if self.source is None:
            return fetch_snapshot(self.master_uri, timeout)  # never raises: a master down is a snapshot too
        try:
            return self.source()
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
            self._publish(self._fetch(self.timeout))
            self._stop.wait(self.period)

    def __enter__(self) -> "GraphCache":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    def __repr__(self) -> str:
        snap = self._snapshot
        state = "up" if snap.master_up else "down"
        return f"<GraphCache {self.where} master {state}, {len(snap.topics)} topics, {'running' if self.running else 'stopped'}>"
