"""The session's executor thread, supervised, and the lanes that keep one blocking handler from holding the others.

One rclpy ``SingleThreadedExecutor`` runs every callback of the session's nodes (why one, and why
that one: :mod:`ipyros.ros2.runtime`). A handler that blocks (``time.sleep(6)``, a slow service
call, a long computation) would hold that thread, and with it every subscription, timer, relay
and guard of the session, for as long as it blocks. So:

* every handler call runs through a :class:`Lane`, which tells the :class:`Spinner` which call holds
  the executor thread and since when (two stores and one uncontended lock per call);
* the spinner's watch looks every :attr:`Spinner.LOOK` seconds: a call that has held the thread for
  :attr:`Spinner.PATIENCE` seconds is left to finish where it is, its lane moves to a thread of its
  own (later calls queue there, in order, after the one still running), and a *new* thread takes
  over spinning the executor at once; the thread that was held ends as soon as its call returns.
  The other callbacks are held up for about a tenth of a second, from the first slow call on;
* a call that ends just after its patience moves its lane as well, from the next call on.

Two threads never wait on the executor at once: a thread spins only while it is the spinner's
current one, and a thread is replaced only while it is inside a handler (under the lock that the
call's end takes too). The session's nodes put every entity in a reentrant callback group
(:class:`HostNode`), so that the new thread may run the other callbacks of the node whose handler
still runs. A callback's exception that escapes rclpy's executor (an error of rclpy's own, a
``SystemExit`` from a callback that is not a handler's) is said in one line, and spinning goes on.
"""

from __future__ import annotations

import collections
import logging
import threading
import time
from typing import Any, Callable, Optional

from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node

from ..core.slots import HandlerSlot

Complain = Callable[[str], None]

__all__ = ["HostNode", "Lane", "Spinner"]


class HostNode(Node):
    """An rclpy node whose endpoints, its parameter services included, are in one reentrant callback group.

    rclpy's default group lets one callback of a node run at a time: while a handler of the node blocks,
    no other callback of it could run even on a new executor thread. The session never runs two calls of
    one handler at once itself (its :class:`Lane` keeps them in order), so nothing needs that exclusion.
    """

    @property
    def default_callback_group(self) -> ReentrantCallbackGroup:
        group = self.__dict__.get("_ipyros_group")
        if group is None:  # made on first use: rclpy's own __init__ asks for it before ours could run
            group = self.__dict__["_ipyros_group"] = ReentrantCallbackGroup()
        return group

    def serve_parameters(self) -> None:
        """Start the parameter services (``ros2 param``'s way in) now, if the node was made without them.

        A session's node has them only once it has a parameter: each is six services, and every entity a node
        has costs at its end (ROS 2 announces the process's whole graph again for each one destroyed: 150 nodes
        with them took 20 s to shut down, without them well under one).
        """
        if getattr(self, "_parameter_service", None) is None:
            from rclpy.parameter_service import ParameterService

            self._parameter_service = ParameterService(self)


class Spinner:
    """Spins one executor on a thread that is replaced whenever a handler holds it (see the module's docstring).

    ``watch``: whether handler calls run on this executor (the session's main one), so that a watch is
    kept; the caller node's executor, which runs no handler, needs none.
    """

    PATIENCE = 0.1  # seconds a handler may hold the executor thread before its lane moves
    LOOK = 0.02  # seconds between two looks of the watch

    def __init__(self, executor: Any, name: str, watch: bool = True) -> None:
        self.executor, self.name = executor, name
        self._lock = threading.Lock()
        self._current: Optional[threading.Thread] = None
        self._threads: list[threading.Thread] = []
        self._busy: Optional[tuple["Lane", float]] = None  # the lane whose call holds the current thread, since
        self._stopping = threading.Event()
        self._watch = threading.Thread(target=self._watching, name=f"{name}-watch", daemon=True) if watch else None

    def start(self) -> None:
        with self._lock:
            self._take_over()
        if self._watch is not None:
            self._watch.start()

    def _take_over(self) -> None:
        """Start a new thread that spins from now on (the lock is held)."""
        thread = threading.Thread(target=self._spin, name=self.name, daemon=True)
        self._current = thread
        self._threads = [t for t in self._threads if t.is_alive()] + [thread]
        thread.start()

    def _spin(self) -> None:
        from rclpy.executors import ExternalShutdownException

        me, executor = threading.current_thread(), self.executor
        while self._current is me and not self._stopping.is_set() and executor.context.ok():
            try:
                executor.spin_once()
            except ExternalShutdownException:
                return
            except BaseException as error:  # noqa: BLE001 - said; the nodes go on
                if self._stopping.is_set() or not executor.context.ok():
                    return
                # A node shut down while the executor held one of its callbacks: rclpy refuses the destroyed
                # handle. Nothing of any node is lost, and shutting down many nodes did it every few nodes.
                gone = type(error).__name__ == "InvalidHandle" and "destruction was requested" in str(error)
                logging.getLogger("ipyros").log(
                    logging.DEBUG if gone else logging.WARNING,
                    "ipyros: a ROS 2 callback raised %s%s, which ended the executor of the session's nodes; it runs "
                    "again (nothing of yours was stopped)", type(error).__name__, f" ({error})" if str(error) else "")

    # -- what the lanes tell --------------------------------------------------------------------
    def entering(self, lane: "Lane") -> None:
        self._busy = (lane, time.monotonic())

    def leaving(self, lane: "Lane") -> bool:
        """The call of ``lane`` on the executor thread ended; whether its lane was moved meanwhile."""
        with self._lock:
            busy = self._busy
            if busy is not None and busy[0] is lane:  # (a thread replaced meanwhile ends its call after another began)
                self._busy = None
            return lane.moved

    def _watching(self) -> None:
        while not self._stopping.wait(self.LOOK):
            busy = self._busy
            if busy is None or time.monotonic() - busy[1] < self.PATIENCE:
                continue
            with self._lock:
                if self._busy is not busy or self._stopping.is_set():  # it ended meanwhile
                    continue
                self._busy = None
                lane = busy[0]
                lane.move(time.monotonic() - busy[1], running=True)
                self._take_over()

    def stop(self, timeout: float = 5.0) -> None:
        """Stop spinning (the executor is shut down by its owner); wait for the threads that can end."""
        self._stopping.set()
        self.executor.wake()
        with self._lock:
            current, threads = self._current, list(self._threads)
        if self._watch is not None and self._watch.ident is not None:
            self._watch.join(timeout)
        for thread in threads:  # a thread left in a handler that never returns stays a daemon
            thread.join(timeout if thread is current else 0.5)


class Lane:
    """Where one handler's calls run: on the executor thread while they are quick, on a thread of its own once
    one is not (see the module's docstring).

    What waits for a slow handler is bounded: at most :attr:`BACKLOG` calls (the oldest are dropped
    and counted); a timer's ticks are not queued up behind one still running (``coalesce``).
    """

    BACKLOG = 1000

    def __init__(self, slot: HandlerSlot, complain: Optional[Complain], what: str, spinner: Optional[Spinner] = None,
                 coalesce: bool = False) -> None:
        self.slot, self._complain, self._what, self._coalesce = slot, complain, what, coalesce
        self._spinner = spinner
        self._queue: Optional[collections.deque] = None
        self._ready = threading.Condition()
        self._closed = False
        self._handed = threading.Event()  # set once no call of this lane runs on the executor thread any more
        self.dropped = 0

    @property
    def moved(self) -> bool:
        return self._queue is not None

    def __call__(self, *args: Any) -> None:
        queue = self._queue
        if queue is not None:
            with self._ready:
                if self._coalesce and queue:
                    return
                if len(queue) >= self.BACKLOG:
                    queue.popleft()
                    self.dropped += 1
                queue.append(args)
                self._ready.notify()
            return
        spinner = self._spinner
        if spinner is None:
            self.slot.run(*args)
            return
        spinner.entering(self)
        start = time.monotonic()
        try:
            self.slot.run(*args)
        finally:
            if spinner.leaving(self):  # moved while it ran: the lane's thread may go on now
                self._handed.set()
            else:
                took = time.monotonic() - start
                if took >= Spinner.PATIENCE and not self._closed:
                    self.move(took, running=False)

    def move(self, took: float, running: bool) -> None:
        """Run this lane's calls on a thread of its own from now on; ``running``: one still runs on the executor
        thread (the lane's thread waits for it, so that the calls stay in order)."""
        if self._queue is not None:
            return
        if not running:
            self._handed.set()
        self._queue = collections.deque()
        threading.Thread(target=self._work, name=f"ipyros-slow-{self.slot.label}", daemon=True).start()
        if self._complain is not None:
            held = f"has held the session's executor for {took:.2f} s and still runs" if running else \
                f"took {took:.2f} s"
            self._complain(f"the handler of {self._what} {held}: every other handler of the session waited "
                           "meanwhile; it runs on a thread of its own from now on, and the others go on")

    def _work(self) -> None:
        self._handed.wait()
        queue = self._queue
        assert queue is not None
        while True:
            with self._ready:
                while not queue and not self._closed:
                    self._ready.wait()
                if self._closed:
                    return
                args = queue.popleft()
            self.slot.run(*args)

    def close(self) -> None:
        with self._ready:
            self._closed = True
            self._ready.notify_all()
        self._handed.set()
