"""A node's guards, live: each one's gate in front of its output, the page it shares with its sentinel process,
the sentinel or the machine that keeps it, and what the prompt is told (:mod:`ipyros.node.liveguard`, :mod:`ipyros.node.placed`).

The engine opens a guard before the output it stands on (the plan lists guards first), hands the
output endpoint its :class:`LiveGuard` (every message the endpoint sends passes it), swaps its rules
when the guard is declared again (nothing reopens), and closes it when the node shuts down (its
sentinel then holds the stop message for its grace) or when the guard is removed (at once).
"""

from __future__ import annotations

import threading
import time
from typing import Any, Callable, Optional

from ..core.guard import GuardState
from ..core.model import GuardModel, TopicModel
from .liveguard import LiveGuard
from .placed import PlacedGuard

__all__ = ["GuardEndpoint", "NodeGuards", "Watch", "guard_of"]

def guard_of(outputs: list[TopicModel], resolved: str) -> Optional[TopicModel]:
    """The output a guard on ``resolved`` stands on, if the node has one there."""
    return next((t for t in outputs if t.resolved == resolved), None)


class Watch:
    """One thread per session that tells the prompt what the guards' processes did (a trip on silence, an e-stop
    by topic, commands passing again), once per change: the sentinels act, the session only says so."""

    LOOK = 0.1  # seconds between two looks

    def __init__(self, notify: Callable[[str], None]) -> None:
        self._notify = notify
        self._guards: list[LiveGuard] = []
        self._lock = threading.Lock()
        self._thread: Optional[threading.Thread] = None

    def add(self, guard: LiveGuard) -> None:
        with self._lock:
            self._guards.append(guard)
            if self._thread is None or not self._thread.is_alive():
                self._thread = threading.Thread(target=self._run, name="ipyros-guards", daemon=True)
                self._thread.start()

    def remove(self, guard: LiveGuard) -> None:
        with self._lock:
            if guard in self._guards:
                self._guards.remove(guard)

    def guards(self) -> list[LiveGuard]:
        with self._lock:
            return list(self._guards)

    def _run(self) -> None:
        while True:
            with self._lock:
                guards = list(self._guards)
                if not guards:
                    self._thread = None
                    return
            for guard in guards:
                for news in (*guard.tend(time.monotonic()), guard.news()):
                    if news is not None:
                        self._notify(f"ipyros: {news}")
            time.sleep(self.LOOK)



class NodeGuards:
    """The guards of one running node, by topic: opened from the plan (before their outputs), handed to the
    output endpoints, told of new rules, e-stopped, shown."""

    def __init__(self, backend: Any, say: Callable[[str], None], watch: "Watch",
                 send: Callable[[str, Any], bool] = lambda topic, msg: False) -> None:
        self._backend, self._say, self._watch, self._send = backend, say, watch, send
        self.live: dict[str, LiveGuard] = {}
        self.ending = False  # set once the node shuts down: its guards then hold the stop message

    def open(self, model: GuardModel, output: TopicModel, host: str) -> "GuardEndpoint":
        """The guard of ``output`` opened (on node ``host``): its process started here, or placed on its machine."""
        if model.machine is not None:
            guard: LiveGuard = PlacedGuard(model, output, self._backend, self._say, self._send, host)
        else:
            guard = LiveGuard(model, output, self._backend, self._say, self._send, host)
        try:
            guard.start()
        except BaseException:
            guard.shared.close()
            raise
        self.live[model.resolved] = guard
        self._watch.add(guard)
        return GuardEndpoint(self, guard)

    def quieten(self) -> None:
        """The node shuts down: its guards will hold the stop message for their grace, as they should, and the
        prompt is not told of that silence."""
        self.ending = True
        for guard in self.live.values():
            self._watch.remove(guard)

    def gate(self, topic: str) -> Optional[LiveGuard]:
        """The guard an output of ``topic`` passes its messages through, if it is guarded."""
        return self.live.get(topic)

    def attach(self, endpoints: dict[Any, Any], output_of: Callable[[Any], Optional[str]]) -> None:
        """Hand each output endpoint its topic's guard (or none): after a guard was added or removed on a running
        node, or an output opened again."""
        for spec, endpoint in endpoints.items():
            topic = output_of(spec)
            if topic is not None and hasattr(endpoint, "gate"):
                endpoint.gate = self.live.get(topic)

    def update(self, guards: list[GuardModel]) -> None:
        for model in guards:
            live = self.live.get(model.resolved)
            if live is not None and live.model != model:
                live.update(model)

    def estop(self, on: bool) -> list[str]:
        """E-stop every guard of the node (or release them); the topics. One that cannot be reached (a guard on a
        machine) never keeps the others from it: each is asked, then the first failure is raised."""
        failed: list[Exception] = []
        for guard in self.live.values():
            try:
                guard.estop(on)
            except Exception as error:  # noqa: BLE001 - raised below, once every guard was asked
                failed.append(error)
        if failed:
            raise failed[0]
        return list(self.live)

    def states(self) -> tuple[GuardState, ...]:
        return tuple(guard.state() for guard in self.live.values())


class GuardEndpoint:
    """A guard as an endpoint of the node's plan: closing it ends the guard (holding the stop message when the
    node shuts down, at once when the guard is removed)."""

    def __init__(self, guards: NodeGuards, guard: LiveGuard) -> None:
        self._guards, self.guard = guards, guard

    def close(self) -> None:
        guards = self._guards
        guards.live.pop(self.guard.topic, None)
        guards._watch.remove(self.guard)
        self.guard.close(hold=guards.ending)
