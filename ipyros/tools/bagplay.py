"""A bag driven while it plays: pause, resume, step, seek, rate and loop (``%bag pause nd``, ...).

The bag player a ``baseBag`` node runs takes its controls as lines on its stdin and answers
each with a state line in its log (:mod:`ipyros.processes.playback`); :func:`control` sends
one and waits for its answer, so that what the prompt shows is where the player stands after
the control, not before.
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass

from ..core.errors import IpyrosError, NodeStateError, NotDeclaredError
from ..core.records import short_repr
from ..dsl import engine_of, rosNode
from ..processes.playback import parse_state

__all__ = ["CONTROLS", "PlayerState", "control"]

#: What ``%bag`` can tell a playing bag (``state``: nothing changes, where it stands).
CONTROLS = ("pause", "resume", "step", "seek", "rate", "loop", "state")

_ids = itertools.count(1)


@dataclass(frozen=True, repr=False)
class PlayerState:
    """Where a bag's playing stands: bag time from its start (s), paused or not, rate, looping, messages sent."""

    node: str
    at: float
    length: float
    paused: bool
    rate: float
    loop: bool
    sent: int

    def __str__(self) -> str:
        return (f"{self.node}'s bag: at {self.at:.3f} of {self.length:.3f} s, "
                f"{'paused' if self.paused else 'playing'} at rate {self.rate:g}{', looping' if self.loop else ''}; "
                f"{self.sent} message{'s' * (self.sent != 1)} sent")

    def __repr__(self) -> str:
        return short_repr(self, str(self), limit=200)


def control(node: rosNode, text: str, timeout: float = 5.0) -> PlayerState:
    """Send ``text`` (``pause``, ``step 3``, ``seek 12.5``, ...) to the bag ``node`` plays; where it stands after."""
    engine = engine_of(node)
    base_model = engine.model().base
    if base_model is None or not base_model.bag:
        raise NotDeclaredError(f"{node.name} plays no bag; declare one first: {engine.called}.baseBag('run.bag')")
    base = engine.base
    if base is None or not base.running:
        raise NodeStateError(f"{node.name}'s bag is not playing (it played to its end, or {engine.called} is not "
                             f"running): {engine.called}.base.restart() plays it again")
    ident = str(next(_ids))
    base.tell(f"{ident} {text}")
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        for line in reversed(base.tail(40)):
            if line.startswith(f"bag_player: state {ident} "):
                _, fields, problem = parse_state(line)
                if problem is not None:
                    raise IpyrosError(f"%bag {text.split()[0]}: {problem}")
                return PlayerState(node.name, float(fields["at"]), float(fields["length"]), fields["paused"] == "1",
                                   float(fields["rate"]), fields["loop"] == "1", int(fields["sent"]))
        if not base.running:
            break
        time.sleep(0.02)
    raise IpyrosError(f"{node.name}'s bag player did not answer '{text}' within {timeout:g} s; its log: "
                      f"{engine.called}.base.tail()")
