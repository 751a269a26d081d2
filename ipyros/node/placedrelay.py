"""The relays of a basenode placed on another machine (its topics, services and actions), run there by its keeper.

A wrapped node's relays carry its basenode's topics to and from their public names (see
:mod:`ipyros.core.plan`). When the basenode runs on the robot (``.machine("robot1")``), relays in
the session would make each of its topics cross the link twice: out to the laptop and back. So
the plan says where each relay runs (:attr:`~ipyros.core.plan.RelaySpec.machine`), and the
keeper of that machine runs it beside the basenode: a camera's images cross the link only to
a handler of the session's that takes them. A relay onto a topic a guard stands on there passes
that guard's gate on the robot (the keeper hands it over); a relay onto a topic guarded in this
session runs here, behind the session's gate (the plan says so).

All the relays of one node share one link (:class:`~ipyros.node.keeperlink.KeeperLink`): one
heartbeat keeps them past their grace, one report tells what each has sent. On the machine they run in
a process of their own, not the keeper's (:mod:`ipyros.processes.relayhost`), except one onto a topic
guarded there, which passes the guard's gate in the keeper.
"""

from __future__ import annotations

import secrets
import threading
from typing import Any, Callable, Optional, Union

from ..core import plan as planning
from ..core.slots import SendFigures
from ..processes.keeper import MachineError
from .keeperlink import KeeperLink

__all__ = ["PlacedRelay", "PlacedRelays", "PlacedSpec"]

#: What a relay the keeper runs is: a topic's, a service's (its calls passed on), an action's (all its parts).
PlacedSpec = Union[planning.RelaySpec, planning.ServiceRelaySpec, planning.ActionRelaySpec]
_KINDS = {planning.RelaySpec: "topic", planning.ServiceRelaySpec: "service", planning.ActionRelaySpec: "action"}

#: How often the relays' heartbeat goes (s): it only keeps them past their grace (no stop message hangs on it).
BEAT = 1.0


class PlacedRelays:
    """The relays of node ``host`` that the keeper of ``machine`` runs; ``grace``: how long it keeps them once
    this session is silent (None: for good, as the basenode)."""

    def __init__(self, backend: Any, host: str, machine: str, grace: Optional[float],
                 say: Callable[[str], None]) -> None:
        self.machine, self.grace = machine, grace
        self._backend, self._host, self._say = backend, host, say
        self._lock = threading.Lock()
        self._link: Optional[KeeperLink] = None
        self._open: dict[str, "PlacedRelay"] = {}
        self._ended_said = False

    def open(self, spec: PlacedSpec) -> "PlacedRelay":
        """Ask the keeper to run ``spec``'s relay; a one-line :class:`MachineError` if it refuses or is not there."""
        with self._lock:
            if self._link is None:
                link = KeeperLink(self._backend, self._host, self.machine, "relays", f"relays of {self._host}",
                                  self._say)
                try:
                    link.open(self._reported)
                    link.beat(BEAT)
                except BaseException:
                    link.close()
                    raise
                self._link = link
            link = self._link
        rid = secrets.token_hex(6)
        try:
            link.ask("relay", timeout=10.0, rid=rid, grace=self.grace,
                     relay={"kind": _KINDS[type(spec)], "source": spec.source, "target": spec.target,
                            "type": spec.type})
        except BaseException:
            self._closed_if_unused()
            raise
        relay = PlacedRelay(self, link, rid, spec)
        with self._lock:
            self._open[rid] = relay
        return relay

    def _reported(self, report: dict[str, Any]) -> None:
        """Say once when the relays' process on the machine ended on its own (its topics are not relayed then)."""
        ended = report.get("ended")
        if ended and not self._ended_said:
            self._ended_said = True
            self._say(f"the relays of {self._host} on machine {self.machine} ended ({ended}): its basenode's topics are "
                      f"not relayed; shutdown() and create() the node to run them again")

    def close(self, relay: "PlacedRelay") -> None:
        with self._lock:
            self._open.pop(relay.id, None)
        try:
            relay.link.ask("unrelay", timeout=3.0, rid=relay.id)
        except MachineError as error:
            self._say(f"relay {relay.spec.source} -> {relay.spec.target}: {error}; the keeper ends it once this "
                      "session is silent past its grace")
        finally:
            self._closed_if_unused()

    def _closed_if_unused(self) -> None:
        with self._lock:
            link = self._link if not self._open else None
            if link is not None:
                self._link = None
        if link is not None:
            link.close()


class PlacedRelay:
    """One relay the keeper runs: the endpoint of the node's plan (closed, shown in ``%status``, and what ``%pub``
    and an e-stop send on its target through)."""

    def __init__(self, relays: PlacedRelays, link: KeeperLink, rid: str, spec: PlacedSpec) -> None:
        self.id, self.spec, self.link, self._relays = rid, spec, link, relays

    def send(self, msg: Any) -> None:
        """``msg`` onto the target, from the relay on the robot (through the guard that stands there, if one does)."""
        data = self._relays._backend.serialize(msg).hex()
        self.link.ask("relay_send", timeout=5.0, rid=self.id, data=data)

    def figures(self) -> Optional[SendFigures]:
        if not isinstance(self.spec, planning.RelaySpec):
            return None  # a service's or an action's relay: no topic it sends on
        messages, connections, dropped = (self.link.report.get("relays") or {}).get(self.id) or (0, 0, 0)
        return SendFigures(self.spec.target, f"relay on {self._relays.machine}", messages, connections, 0, dropped)

    def close(self) -> None:
        self._relays.close(self)
