"""A guard's own process's loop (:func:`ipyros.processes.sentinel.watch`), pure: its clock and its waits are the
test's, so the stop on silence, the stop message's rate, a command that ends it, an e-stop and the hold after the
session's end are checked to the millisecond, without ROS and without waiting."""

from __future__ import annotations

import threading

import pytest

from ipyros.processes import sentinel
from ipyros.processes.sentinel import Shared

PASSING, STOPPED, ESTOPPED = sentinel.PASSING, sentinel.STOPPED, sentinel.ESTOPPED

MS = 1_000_000  # ns


class Clock:
    """Monotonic time in ns that moves only when a wait says so."""

    def __init__(self) -> None:
        self.now = 1_000 * MS

    def __call__(self) -> int:
        return self.now


class Event(threading.Event):
    """An event whose waits take no time on the wall, only on the test's clock."""

    def __init__(self, clock: Clock) -> None:
        super().__init__()
        self.clock = clock

    def wait(self, timeout: float | None = None) -> bool:  # type: ignore[override]
        if not self.is_set() and timeout is not None:
            self.clock.now += int(timeout * 1e9)
        return self.is_set()


@pytest.fixture
def shared():
    page = Shared.create()
    yield page
    page.close()


def run(shared: Shared, settings: dict, script) -> list[tuple[int, int]]:
    """Run the loop; ``script(n, clock, events)`` is called at each stop message sent (the n-th, from 1) and may
    act; the ``(ms since the start, state)`` of each stop message."""
    clock = Clock()
    gone, wake, quit_now = Event(clock), Event(clock), Event(clock)
    start = clock.now
    shared.passed(at=start)
    sent: list[tuple[int, int]] = []

    def publish_stop() -> None:
        sent.append(((clock.now - start) // MS, shared.state))
        if len(sent) > 500:  # a loop gone wrong ends the test, not the run
            quit_now.set()
        script(len(sent), clock, {"gone": gone, "wake": wake, "quit": quit_now})

    sentinel.watch(shared, settings, publish_stop, gone, wake, quit_now, clock)
    return sent


def test_silence_brings_the_stop_message_at_its_rate_until_a_command_passes(shared):
    def script(n, clock, events):
        if n == 3:  # a command passes between the 3rd and the 4th stop message
            clock.now += 20 * MS
            shared.passed(at=clock.now)
            passed_at.append(clock.now)
        if n == 4:
            events["quit"].set()

    passed_at: list[int] = []
    sent = run(shared, {"timeout": 0.5, "repeat": 10.0, "grace": 0.0}, script)
    times = [t for t, _ in sent]
    assert times[:3] == [500, 600, 700], times  # the timeout after the last pass, then every 100 ms
    assert all(state == STOPPED for _, state in sent)
    # the command ended the stopping at once (within a 5 ms poll); silence again: 500 ms after it
    assert times[3] - times[2] >= 500 + 20 and times[3] - times[2] <= 500 + 20 + 10, times
    assert shared.stops_sent == 4


def test_an_estop_holds_the_stop_message_whatever_passes_and_a_release_ends_it(shared):
    def script(n, clock, events):
        shared.passed(at=clock.now)  # commands keep coming: an e-stop holds all the same
        if n == 5:
            shared.estop_session = False
            released.append(clock.now)

    def stop_soon(timeout=None):  # after the release, a few waits: the loop is passing, sending nothing
        if released:
            waits.append(timeout)
            if len(waits) >= 3:
                quit_now.set()

    released: list[int] = []
    waits: list[float] = []
    shared.estop_session = True
    clock = Clock()
    gone, wake, quit_now = Event(clock), Event(clock), Event(clock)
    original = wake.wait
    wake.wait = lambda timeout=None: (stop_soon(timeout), original(timeout))[1]  # type: ignore[method-assign]
    start = clock.now
    shared.passed(at=start)
    sent: list[tuple[int, int]] = []

    def publish_stop() -> None:
        sent.append(((clock.now - start) // MS, shared.state))
        script(len(sent), clock, {})

    sentinel.watch(shared, {"timeout": None, "repeat": 20.0}, publish_stop, gone, wake, quit_now, clock)
    assert [t for t, _ in sent] == [0, 50, 100, 150, 200], sent  # at its rate, whatever passes; none after release
    assert all(state == ESTOPPED for _, state in sent) and shared.state == PASSING


def test_the_session_gone_the_stop_message_is_held_for_its_grace_then_the_loop_ends(shared):
    def script(n, clock, events):
        if n == 1:
            events["gone"].set()

    sent = run(shared, {"timeout": 0.2, "repeat": 10.0, "grace": 1.0}, script)
    held = [t for t, _ in sent[1:]]
    assert held[0] - sent[0][0] <= 100 and held[-1] - held[0] <= 1000, sent
    assert 10 <= len(held) <= 11 and shared.state == STOPPED, sent


def test_without_a_timeout_nothing_is_sent_while_passing(shared):
    clock = Clock()
    gone, quit_now = Event(clock), Event(clock)
    waits: list[float] = []

    class Counting(Event):
        def wait(self, timeout=None):
            waits.append(timeout)
            if len(waits) >= 3:
                quit_now.set()
            return super().wait(timeout)

    sent: list[int] = []
    shared.passed(at=clock.now)
    sentinel.watch(shared, {"timeout": None, "repeat": 10.0}, lambda: sent.append(clock.now), gone, Counting(clock),
                   quit_now, clock)
    assert sent == [] and shared.state == PASSING and len(waits) == 3
