"""The part of a guard that sends the stop message, in a small process of the session's own (its *sentinel*).

A guard must hold when the session itself stops: a handler in an endless loop holding the GIL,
a breakpoint, ``time.sleep`` typed at the prompt, Ctrl-Z (which stops the whole foreground process
group), a kernel killed. So the stop on silence is not sent from the session: each guard has a
process of its own, in a process group of its own (Ctrl-Z does not reach it), started without
the death signal of the session's other children, that publishes on the guarded topic too:

* the session's gate writes, into a page of memory both map (:class:`Shared`), the monotonic time
  of each message it lets through; the sentinel sleeps until that time plus ``timeout`` and, if
  nothing newer came, sends the stop message and again at ``repeat`` Hz until a fresh message
  passes. Its clock is the steady one (``CLOCK_MONOTONIC``, the same in every process), never a
  ROS clock: a watchdog on sim time never fires when the clock stops;
* an e-stop (``%estop``: the session sets a flag there; or a ``std_msgs/Bool`` e-stop topic, which
  the sentinel itself hears, so that a second terminal still trips it while the session is frozen)
  makes it send the stop message at ``repeat`` Hz until released;
* the session holds the write end of a pipe whose read end is the sentinel's: when the session
  ends for good (exit, SIGTERM, SIGKILL) the sentinel reads the end of it, holds the stop message
  for ``grace`` seconds (at most ten), then exits. Nothing is left running.

This module is the ROS-free part: the shared page, the session's handle on its sentinel, and the
sentinel's loop. What publishes (rospy, rclpy) is each backend's ``sentinel`` module.
"""

from __future__ import annotations

import json
import mmap
import os
import signal
import subprocess
import threading
import time
from typing import Any, Callable, Optional, Sequence

__all__ = ["PASSING", "STOPPED", "ESTOPPED", "Sentinel", "Shared", "watch"]

PASSING, STOPPED, ESTOPPED = 0, 1, 2
STATES = {PASSING: "passing", STOPPED: "stopped on silence", ESTOPPED: "e-stopped"}


class Shared:
    """The page a guard's gate (in the session) and its sentinel both map: 64-bit words, each written whole.

    ======  =============================================================================
    word    what
    ======  =============================================================================
    0       the monotonic time (ns) the last message passed the gate (the session writes)
    1       e-stopped by the session (``%estop``), 0 or 1 (the session writes)
    2       e-stopped by the guard's e-stop topic, 0 or 1 (the sentinel writes)
    3       stop messages the sentinel sent (the sentinel writes)
    4       its state: passing, stopped on silence, e-stopped (the sentinel writes)
    5       the monotonic time (ns) of its last trip (the sentinel writes)
    6       1 once it publishes on the topic (the sentinel writes)
    7       how many subscribers of the topic its publisher reaches (the sentinel writes)
    8       held for a lost lease, 0 or 1 (a keeper writes: the session placing the guard is not heard)
    ======  =============================================================================
    """

    SIZE = 4096

    def __init__(self, fd: int) -> None:
        self.fd = fd
        self._map = mmap.mmap(fd, self.SIZE)
        self._words = memoryview(self._map).cast("q")  # aligned 8-byte stores: never seen half-written

    @classmethod
    def create(cls) -> "Shared":
        """A new page, in memory only (no file to leave behind)."""
        fd = os.memfd_create("ipyros-guard", 0)
        os.ftruncate(fd, cls.SIZE)
        return cls(fd)

    def passed(self, at: Optional[int] = None) -> None:
        """A message passed the gate, now (or ``at``, a monotonic time in ns: a test's clock)."""
        self._words[0] = time.monotonic_ns() if at is None else at

    @property
    def last_pass(self) -> int:
        return self._words[0]

    estop_session = property(lambda self: bool(self._words[1]),
                             lambda self, on: self._words.__setitem__(1, int(bool(on))))
    estop_topic = property(lambda self: bool(self._words[2]),
                           lambda self, on: self._words.__setitem__(2, int(bool(on))))
    stops_sent = property(lambda self: self._words[3], lambda self, n: self._words.__setitem__(3, n))
    state = property(lambda self: self._words[4], lambda self, s: self._words.__setitem__(4, s))
    tripped_at = property(lambda self: self._words[5], lambda self, t: self._words.__setitem__(5, t))
    ready = property(lambda self: bool(self._words[6]), lambda self, on: self._words.__setitem__(6, int(on)))
    reach = property(lambda self: self._words[7], lambda self, n: self._words.__setitem__(7, n))
    held = property(lambda self: bool(self._words[8]), lambda self, on: self._words.__setitem__(8, int(bool(on))))

    @property
    def estopped(self) -> bool:
        """E-stopped by the session or its topic, or held by a keeper (words 1, 2, 8): read on every message."""
        words = self._words
        return bool(words[1] or words[2] or words[8])

    def close(self) -> None:
        self._words.release()
        self._map.close()
        os.close(self.fd)


# -- the session's side -------------------------------------------------------------------------

class Sentinel:
    """The session's handle on one guard's sentinel process: started with its settings, told when they change,
    ended (at once, or holding the stop message for its grace, as when the session itself ends)."""

    def __init__(self, argv: Sequence[str], settings: dict[str, Any], shared: Shared, log_path: Any,
                 env: Optional[dict[str, str]] = None) -> None:
        read, self._write = os.pipe()
        self.shared, self.log_path = shared, log_path
        try:
            with open(log_path, "ab", buffering=0) as log:
                # Its own process group (Ctrl-Z at the terminal stops the foreground group: not it); no death signal:
                # it must outlive the session by its grace, and it ends by itself when the pipe closes.
                self._proc = subprocess.Popen([*argv, str(read), str(shared.fd)], pass_fds=(read, shared.fd),
                                              stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT,
                                              process_group=0, env=env)
        finally:
            os.close(read)
        self.pid = self._proc.pid
        self.tell(settings)

    def tell(self, message: dict[str, Any]) -> None:
        """A line to the sentinel: its settings (the first), a change of them, a wake-up after an e-stop."""
        os.write(self._write, (json.dumps(message) + "\n").encode())

    def ready(self, timeout: float) -> Optional[str]:
        """Wait until it publishes on the topic (None), or the reason it could not (its last words in its log)."""
        deadline = time.monotonic() + timeout
        while not self.shared.ready and self._proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
        if self.shared.ready:
            return None
        ended = self._proc.poll() is not None
        self.end(hold=False)
        try:
            with open(self.log_path, encoding="utf-8", errors="replace") as log:
                lines = [line.strip() for line in log if line.strip()]
        except OSError:
            lines = []
        return lines[-1] if ended and lines else f"it did not start within {timeout:g} s"

    @property
    def running(self) -> bool:
        return self._proc.poll() is None

    @property
    def returncode(self) -> Optional[int]:
        """How it ended (negative: the signal that ended it), None while it runs."""
        return self._proc.poll()

    def end(self, hold: bool = True, wait: bool = True, timeout: float = 15.0) -> None:
        """End it: holding the stop message for its grace (``hold``, what the session's end does), or at once;
        ``wait`` for it to exit, else it is reaped by a thread of its own once its grace is over."""
        if self._write >= 0:
            if not hold:
                try:
                    self.tell({"quit": True})
                except OSError:
                    pass
            os.close(self._write)
            self._write = -1
        if not wait:
            threading.Thread(target=self._reap, args=(timeout,), name="ipyros-sentinel-end", daemon=True).start()
            return
        self._reap(timeout)

    def _reap(self, timeout: float) -> None:
        try:
            self._proc.wait(timeout)
        except subprocess.TimeoutExpired:
            os.killpg(self._proc.pid, signal.SIGKILL)
            self._proc.wait()


# -- the sentinel's side --------------------------------------------------------------------------

def watch(shared: Shared, settings: dict[str, Any], publish_stop: Callable[[], None], gone: threading.Event,
          wake: threading.Event, quit_now: threading.Event,
          clock: Callable[[], int] = time.monotonic_ns) -> None:
    """The sentinel's loop: send the stop message on silence and while e-stopped, at ``repeat`` Hz, until a fresh
    message passes; when the session is ``gone``, hold it for ``grace`` seconds and return. ``settings`` may
    change while it runs (its ``timeout``, ``repeat``, ``grace``); ``wake`` ends a wait early."""
    while not quit_now.is_set():
        now = clock()
        timeout = settings.get("timeout")
        period = 1.0 / settings.get("repeat", 10.0)
        if gone.is_set():
            _hold(shared, publish_stop, period, float(settings.get("grace", 3.0)), quit_now, clock)
            return
        last = shared.last_pass
        silent = timeout is not None and now - last >= timeout * 1e9
        if shared.estopped or silent:
            state = ESTOPPED if shared.estopped else STOPPED
            if shared.state != state:
                shared.state, shared.tripped_at = state, now
            publish_stop()
            shared.stops_sent += 1
            _wait_while_stopped(shared, last, period, wake, gone, clock)
            continue
        shared.state = PASSING
        # Asleep until the silence would be long enough; an e-stop or a change of settings wakes it sooner.
        wait = (last + timeout * 1e9 - now) / 1e9 if timeout is not None else 0.5
        wake.wait(max(wait, 0.0) + 1e-4)
        wake.clear()


def _wait_while_stopped(shared: Shared, last: int, period: float, wake: threading.Event, gone: threading.Event,
                        clock: Callable[[], int]) -> None:
    """A period between two stop messages, cut short (within 5 ms) by a fresh message or a release."""
    until = clock() + period * 1e9
    estopped = shared.estopped
    while clock() < until and not gone.is_set():
        if shared.last_pass != last and not shared.estopped or estopped and not shared.estopped:
            return
        wake.wait(min(0.005, max((until - clock()) / 1e9, 0.0)))
        wake.clear()


def _hold(shared: Shared, publish_stop: Callable[[], None], period: float, grace: float,
          quit_now: threading.Event, clock: Callable[[], int] = time.monotonic_ns) -> None:
    """The session is gone: the stop message, again and again, for ``grace`` seconds."""
    shared.state = STOPPED
    end = clock() + grace * 1e9
    while clock() < end and not quit_now.is_set():
        publish_stop()
        shared.stops_sent += 1
        quit_now.wait(min(period, max((end - clock()) / 1e9, 0.0)))


#: How often the sentinel notes how many subscribers it reaches (s).
REACH_LOOK = 0.2


def serve(pipe_fd: int, shared_fd: int,
          start: Callable[[dict[str, Any], Shared, threading.Event], tuple[Callable[[], None], Callable[[], int]]],
          stop_ros: Callable[[], None]) -> int:
    """The sentinel process's main, around its ROS (``start(settings, shared, wake)`` publishes and returns how
    to send the stop message and how many subscribers that reaches; ``stop_ros()`` ends it): the first line of
    the pipe is its settings, later lines change them, the pipe's end is the session's."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the session's Ctrl-C is not for it (nor does it reach it)
    pipe = os.fdopen(pipe_fd, "r")
    shared = Shared(shared_fd)
    first = pipe.readline()
    if not first:
        return 0
    settings = json.loads(first)
    gone, wake, quit_now = threading.Event(), threading.Event(), threading.Event()
    def ended(*_: Any) -> None:  # ended from outside: as the session's end
        gone.set()
        wake.set()

    signal.signal(signal.SIGTERM, ended)
    publish_stop, reach = start(settings, shared, wake)
    if not shared.last_pass:  # the silence counts from the guard's start, not from the machine's boot
        shared.passed()
    shared.ready = True

    def listen() -> None:
        for line in pipe:
            told = json.loads(line)
            if told.get("quit"):
                quit_now.set()
                break
            settings.update(told.get("settings", {}))
            wake.set()
        gone.set()
        wake.set()

    def look() -> None:  # a stop message reaches only the subscribers its publisher has found: the session shows it
        while not quit_now.wait(REACH_LOOK):
            try:
                shared.reach = reach()
            except Exception:  # noqa: BLE001 - ROS ending under it
                return

    threading.Thread(target=listen, name="ipyros-sentinel-pipe", daemon=True).start()
    threading.Thread(target=look, name="ipyros-sentinel-reach", daemon=True).start()
    try:
        watch(shared, settings, publish_stop, gone, wake, quit_now)
    finally:
        stop_ros()
    return 0
