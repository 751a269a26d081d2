"""Where a bag's playing stands, and the controls that change it: pure, on a clock it is given.

A bag player (``ipyros/ros1/bag_player.py``, ``ipyros/ros2/bag_player.py``) keeps one
:class:`Playback`: the *bag time* it has reached (nanoseconds, the bag's own stamps),
whether it is paused, its rate and whether it loops. Playing, bag time runs at ``rate``
times the steady clock from where it was when it last changed; paused, it stands still.
A message is due when bag time reaches its stamp (:meth:`Playback.wait`); the player
publishes it and tells :meth:`Playback.sent`.

The session controls the player by lines on its stdin (``BaseProcess.tell``), each with an
id; the player answers each with one :meth:`Playback.state` line in its log, which the
session waits for::

    7 pause            7 resume          7 step 3 (the next 3 messages, paused)
    7 seek 12.5        (seconds from the bag's start)
    7 rate 2           7 loop on|off     7 state (nothing changes: where it stands)

The players load this file by its path, without ipyros: it needs only the standard library.
"""

from __future__ import annotations

import argparse
import math
import queue
import sys
import threading
import time
from typing import Any, Callable, Iterator, Optional

__all__ = ["Playback", "parse_player_args", "parse_state", "play", "player_args", "read_controls"]

#: What a player reads from a bag: ``(topic, stamp in ns, message)`` in recorded order, from a stamp on (None: all).
Read = Callable[[Optional[int]], Iterator[tuple[str, int, Any]]]


class Playback:
    """A bag's playing from ``start`` to ``end`` (ns, the bag's stamps), on ``clock`` (s, steady)."""

    def __init__(self, start: int, end: int, rate: float = 1.0, loop: bool = False,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.start, self.end, self.rate, self.loop = start, end, rate, loop
        self.paused = False
        self.steps = 0  # messages still to send at once, paused (step N)
        self.sent_count = 0
        self.seek_to: Optional[int] = None  # set by seek: where the player must read from next (ns)
        self._clock = clock
        self._anchor_bag, self._anchor_wall = start, clock()

    # -- bag time --------------------------------------------------------------------------------
    def now(self) -> int:
        """Bag time now (ns): for the ``/clock`` the player publishes."""
        if self.paused or self.steps:
            return self._anchor_bag
        return self._anchor_bag + int((self._clock() - self._anchor_wall) * self.rate * 1e9)

    def _anchor(self, bag: int) -> None:
        self._anchor_bag, self._anchor_wall = bag, self._clock()

    def wait(self, stamp: int) -> float:
        """Seconds of the steady clock until the message stamped ``stamp`` is due (0: now; inf: paused)."""
        if self.steps:
            return 0.0
        if self.paused:
            return math.inf
        return max(0.0, (stamp - self.now()) / 1e9 / self.rate)

    def sent(self, stamp: int) -> None:
        """The message stamped ``stamp`` went out: bag time is at least there."""
        self.sent_count += 1
        if self.steps:
            self.steps -= 1
            self._anchor(max(stamp, self._anchor_bag))
        elif stamp > self.now():  # late only by the player's own delay: time does not jump back
            self._anchor(stamp)

    def restarted(self) -> None:
        """Played to the end and looping: bag time is the start again."""
        self._anchor(self.start)

    # -- controls ------------------------------------------------------------------------------------
    def command(self, text: str) -> Optional[str]:
        """Apply one control (see the module's docstring); what is wrong with it, in one line, or None."""
        word, _, value = text.strip().partition(" ")
        value = value.strip()
        try:
            if word == "pause":
                self._anchor(self.now())
                self.paused = True
            elif word == "resume":
                self._anchor(self.now())
                self.paused, self.steps = False, 0
            elif word == "step":
                count = int(value or "1")
                if count < 1:
                    return f"step {count}: give how many messages to send, 1 or more"
                self._anchor(self.now())
                self.paused, self.steps = True, self.steps + count
            elif word == "seek":
                seconds = float(value)
                if not 0 <= seconds <= (self.end - self.start) / 1e9 or not math.isfinite(seconds):
                    return (f"seek {value}: the bag lasts {(self.end - self.start) / 1e9:.3f} s; give seconds "
                            "from its start, 0 to that")
                self.seek_to = self.start + int(seconds * 1e9)
                self.steps = 0
                self._anchor(self.seek_to)
            elif word == "rate":
                rate = float(value)
                if not 0 < rate <= 1000 or not math.isfinite(rate):
                    return f"rate {value}: give a speed factor above 0 and at most 1000 (1 as recorded)"
                self._anchor(self.now())
                self.rate = rate
            elif word == "loop":
                if value not in ("on", "off"):
                    return f"loop {value}: give on or off"
                self.loop = value == "on"
            elif word != "state":
                return f"{word!r}: the controls are pause, resume, step N, seek SECONDS, rate R, loop on|off"
        except ValueError:
            return f"{text.strip()}: {word} takes a number"
        return None

    def state(self, ident: str, problem: Optional[str] = None) -> str:
        """The line that answers control ``ident``: where the playing stands (and what was wrong, if anything)."""
        line = (f"bag_player: state {ident} at={(self.now() - self.start) / 1e9:.3f} paused={int(self.paused)} "
                f"rate={self.rate:g} loop={int(self.loop)} sent={self.sent_count} "
                f"length={(self.end - self.start) / 1e9:.3f}")
        return line + (f" problem={problem}" if problem else "")


def parse_state(line: str) -> tuple[str, dict[str, str], Optional[str]]:
    """A state line read back: ``(ident, {"at": ..., "paused": ..., ...}, problem or None)``."""
    head, _, problem = line.partition(" problem=")
    words = head.split()
    ident = words[2] if len(words) > 2 else ""
    fields = dict(word.split("=", 1) for word in words[3:] if "=" in word)
    return ident, fields, problem or None


def player_args(path: Any, rate: float, loop: bool, topics: Optional[list[str]], delay: float,
                clock: bool = False) -> list[str]:
    """A player's arguments (either ROS's): ``--delay`` lets the wrapping node's subscribers connect after each
    advertise, so that the first messages are not lost; ``--topics`` last (every word after it is a topic)."""
    args = [str(path), "--rate", f"{rate:g}", "--delay", f"{delay:g}"]
    if loop:
        args.append("--loop")
    if clock:
        args.append("--clock")
    if topics:
        args += ["--topics", *topics]
    return args


def parse_player_args(argv: list[str]) -> argparse.Namespace:
    """What a player (either ROS's) reads of the arguments :func:`player_args` made (ROS's own already removed):
    ``bag``, ``rate``, ``loop``, ``delay``, ``clock``, ``topics`` (None: every topic)."""
    parser = argparse.ArgumentParser(prog="bag_player")
    parser.add_argument("bag")
    parser.add_argument("--rate", type=float, default=1.0)
    parser.add_argument("--loop", action="store_true")
    parser.add_argument("--delay", type=float, default=1.0)
    parser.add_argument("--clock", action="store_true")
    parser.add_argument("--topics", nargs="*")
    return parser.parse_args(argv)


def read_controls() -> "queue.Queue[str]":
    """The lines of this process's stdin, as they come (a thread of its own reads them; none at its end)."""
    lines: "queue.Queue[str]" = queue.Queue()

    def read() -> None:
        for line in sys.stdin:
            if line.strip():
                lines.put(line.strip())

    threading.Thread(target=read, name="controls", daemon=True).start()
    return lines


def play(playback: Playback, read: Read, publish: Callable[[str, Any], None], controls: "queue.Queue[str]",
         ok: Callable[[], bool]) -> None:
    """Play the bag: each message when bag time reaches its stamp, the controls applied as they come (each
    answered with a state line on stdout), again from the start while looping, until the end or not ``ok()``."""
    messages, pending = read(None), None

    def apply(line: str) -> None:
        nonlocal messages, pending
        ident, _, text = line.partition(" ")
        problem = playback.command(text)
        if playback.seek_to is not None:
            messages, pending, playback.seek_to = read(playback.seek_to), None, None
        print(playback.state(ident, problem), flush=True)

    while ok():
        while not controls.empty():
            apply(controls.get_nowait())
        if pending is None:
            pending = next(messages, None)
            if pending is None:
                print("bag_player: played to the end", flush=True)
                if not playback.loop:
                    return
                playback.restarted()
                messages = read(None)
                continue
        wait = playback.wait(pending[1])
        if wait > 0:
            try:  # a control may come meanwhile: it is applied at once
                apply(controls.get(timeout=min(wait, 0.1)))
            except queue.Empty:
                pass
            continue
        topic, stamp, msg = pending
        pending = None
        publish(topic, msg)
        playback.sent(stamp)
