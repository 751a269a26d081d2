"""The ROS 1 graph, read from the master: one XML-RPC round trip, with a timeout.

Why plain XML-RPC and not rospy: the master API is a documented XML-RPC interface (the
same one ``rosgraph.Master`` wraps), reading it needs no ROS node, and rospy allows only
one node per process, which belongs to the ipyros runtime. ``rosgraph.Master`` itself has
no socket timeout, so a master that stops answering would freeze the reader forever; here
every call has a short timeout through a custom transport (:func:`~ipyros.ros1.master.master_proxy`).
"""

from __future__ import annotations

import http.client
import time
import xmlrpc.client
from xml.parsers.expat import ExpatError

from ..core.graph import GraphSnapshot, frozen
from .master import master_proxy

__all__ = ["CALLER_ID", "fetch_snapshot"]

#: The caller id the master sees in its logs for our read-only queries.
CALLER_ID = "/ipyros_graph"

#: Everything a broken, absent or misbehaving master can make an XML-RPC call raise.
_NETWORK_ERRORS = (OSError, xmlrpc.client.Error, http.client.HTTPException, ExpatError, ValueError, TypeError)


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
