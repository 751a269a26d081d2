"""Handler slots: the one place a ROS callback enters user code.

A subscription, timer or service calls its slot, and the slot calls whatever handler
it holds *now*. Swapping a handler is one attribute assignment, atomic under the GIL,
so every message is handled by exactly one handler, old or new, and none is lost:
the ROS subscription itself is never touched. The slot also keeps the figures the
status table shows, the last messages for trying a candidate handler, and turns a
handler's exception into a report instead of a dead callback thread.
"""

from __future__ import annotations

import inspect
import threading
import time
import traceback
from collections import deque
from dataclasses import dataclass
from typing import Any, Callable, NamedTuple, Optional, Protocol

from .errors import HandlerError

Report = Callable[["HandlerFailure"], None]


@dataclass(frozen=True)
class HandlerFailure:
    """One handler exception, with the handler's own traceback (not rospy's)."""

    label: str  # e.g. "turtle_control_node /turtle1/pose"
    handler: str
    error: BaseException
    traceback: str
    suppressed: int  # failures of this slot not reported since the last report


@dataclass(frozen=True)
class SlotFigures:
    """What a slot has seen so far; rates are over the recent calls."""

    calls: int
    errors: int
    rate_hz: float
    mean_ms: float
    max_ms: float


@dataclass(frozen=True)
class SendFigures:
    """What one publication or relay of a node has sent, and what its slow subscribers lost."""

    topic: str
    kind: str  # "publish" or "relay"
    messages: int
    connections: int
    waiting: int  # messages queued now for subscribers that cannot keep up
    dropped: int  # messages dropped for them so far


class OutputScope(Protocol):
    """Where a handler's prints go while it runs (a Jupyter cell's output area, say).

    ``enter`` is called before each handler call on the calling thread, ``leave`` after
    it with what ``enter`` returned.
    """

    def enter(self) -> Any: ...

    def leave(self, previous: Any) -> None: ...


class Arrival(NamedTuple):
    """What the ROS layer knows of the message a handler is handling, beyond the message itself.

    Tools that measure a topic (``%hz``, ``%bw``) need it: a latched message that a new
    subscriber is sent again was not published now, and two publishers make one topic.
    """

    sender: str  # the publishing node (ROS 1) or publisher (ROS 2)
    size: int  # bytes on the wire
    replayed: bool  # a latched (transient-local) message sent again on connecting, not published now


_handling = threading.local()


def arrival() -> Optional[Arrival]:
    """The :class:`Arrival` of the message the calling thread's handler is handling (None outside one)."""
    return getattr(_handling, "arrival", None)


class Pristine:
    """A message kept as it arrived, made again on each request.

    A handler may change the message it was given in place (the paper's ``controlVelocity``
    does), so a slot keeping recent messages for ``%try`` keeps how to make them again,
    e.g. from their bytes, instead of the object the live handler got.
    """

    __slots__ = ("make",)

    def __init__(self, make: Callable[[], Any]) -> None:
        self.make = make


class HandlerSlot:
    """Calls the current handler; counts calls, time and exceptions.

    ``report`` gets at most one failure per ``report_interval`` seconds per slot;
    the others are counted and mentioned in the next report.
    """

    def __init__(
        self,
        label: str,
        handler: Callable[..., Any],
        report: Report,
        *,
        pass_argument: int = True,  # 0: no argument, 1: one, 2: an action's goal and call
        keep: int = 20,
        report_interval: float = 5.0,
        output: Optional[OutputScope] = None,
    ) -> None:
        self.label = label
        self.output = output
        self._current = (handler, pass_argument)
        self.recent: deque[Any] = deque(maxlen=keep)
        self._report = report
        self._report_interval = report_interval
        self._lock = threading.Lock()  # figures only; never held while the handler runs
        self._calls = 0
        self._errors = 0
        self._total_s = 0.0
        self._max_s = 0.0
        self._stamps: deque[float] = deque(maxlen=200)
        self._last_report = -float("inf")
        self._suppressed = 0
        #: Set while the node shuts down: a last call that fails because its topics close is not news.
        self.closing = False

    def swap(self, handler: Callable[..., Any], pass_argument: int = True) -> None:
        """Make ``handler`` serve every call from now on."""
        # One tuple assignment: a callback reads both fields from the same handler.
        self._current = (handler, pass_argument)

    @property
    def handler(self) -> Callable[..., Any]:
        return self._current[0]

    @property
    def pass_argument(self) -> bool:
        return bool(self._current[1])

    def __call__(self, arg: Any = None) -> Any:
        return self.run(arg)[1]

    def run(self, arg: Any = None, pristine: Optional[Pristine] = None,
            came: Optional[Arrival] = None) -> tuple[bool, Any]:
        """Call the handler: ``(True, what it returned)``, or ``(False, None)`` once its exception is reported.

        ``pristine`` makes ``arg`` again as it arrived; without it ``arg`` itself is kept.
        ``came`` is what :func:`arrival` tells the handler.
        """
        handler, pass_argument = self._current
        if arg is not None:
            self.recent.append(arg if pristine is None else pristine)
        call = handler
        if isinstance(arg, GoalArguments):  # an action's goal: handler(goal, action) or handler(goal)
            arg, self.recent[-1] = (arg if pass_argument == 2 else arg[:1]), arg[0]
            call = _spread(handler)
        _handling.arrival = came
        output = self.output
        previous = output.enter() if output is not None else None
        start = time.perf_counter()
        try:
            return True, (call(arg) if pass_argument else call())
        except BaseException as error:  # a handler's bug must never kill the node, not even sys.exit()
            if isinstance(error, KeyboardInterrupt) and threading.current_thread() is threading.main_thread():
                raise  # Ctrl-C at the prompt (a handler tried there): the user's, not the handler's
            self._failed(handler, error)
            return False, None
        finally:
            elapsed = time.perf_counter() - start
            with self._lock:
                self._calls += 1
                self._total_s += elapsed
                self._max_s = max(self._max_s, elapsed)
                self._stamps.append(start)
            if output is not None:
                output.leave(previous)

    def recent_messages(self) -> list[Any]:
        """The last messages the slot got, oldest first, as they arrived (made again where it can)."""
        return [kept.make() if isinstance(kept, Pristine) else kept for kept in list(self.recent)]

    def fail(self, error: Exception) -> None:
        """Count and report a failure found after the handler returned (e.g. a wrong response)."""
        self._failed(self.handler, error, with_traceback=False)

    def _failed(self, handler: Callable[..., Any], error: BaseException, with_traceback: bool = True) -> None:
        if self.closing:
            return
        with self._lock:
            self._errors += 1
            now = time.monotonic()
            if now - self._last_report < self._report_interval:
                self._suppressed += 1
                return
            self._last_report, suppressed, self._suppressed = now, self._suppressed, 0
        # Drop this frame: the user wants their handler's traceback, not ours.
        tb = error.__traceback__.tb_next if error.__traceback__ and with_traceback else None
        text = "".join(traceback.format_exception(type(error), error, tb)) if with_traceback else f"{error}\n"
        name = getattr(handler, "__name__", repr(handler))
        self._report(HandlerFailure(self.label, name, error, text, suppressed))

    def figures(self) -> SlotFigures:
        with self._lock:
            stamps = list(self._stamps)
            calls, errors, total, peak = self._calls, self._errors, self._total_s, self._max_s
        rate = 0.0
        if len(stamps) > 1 and time.perf_counter() - stamps[-1] < 2.0:
            rate = (len(stamps) - 1) / max(stamps[-1] - stamps[0], 1e-9)
        mean = (total / calls * 1e3) if calls else 0.0
        return SlotFigures(calls, errors, rate, mean, peak * 1e3)


class GoalArguments(tuple):
    """What an action's slot is called with: ``(goal, action)``, given to the handler as it takes them."""


def _spread(handler: Callable[..., Any]) -> Callable[[tuple], Any]:
    return lambda arguments: handler(*arguments)


def call_arity(handler: Any, what: str, label: str) -> int:
    """Check ``handler`` can be called by ROS; return whether it takes the one argument.

    Subscriptions and services pass one argument (message, request); timers pass the
    timer event, which a handler may also do without; an action's handler takes the goal
    and may take the :class:`~ipyros.core.actions.ActionCall` too (then 2 is returned).
    """
    if not callable(handler):
        raise HandlerError(f"handler for {label} is {type(handler).__name__} {handler!r}, not a function; "
                           "pass the function itself, e.g. handler=showPose (no parentheses)")
    name = getattr(handler, "__name__", "handler")
    # ROS calls handlers on its own threads and uses what they return at once: a coroutine
    # or generator would be created and dropped without its body ever running.
    if inspect.iscoroutinefunction(handler) or inspect.isasyncgenfunction(handler):
        raise HandlerError(f"handler {name} for {label} is an async def: ROS calls it on its own thread "
                           "and would never await it; make it a plain def (call asyncio.run(...) inside if needed)")
    if inspect.isgeneratorfunction(handler):
        raise HandlerError(f"handler {name} for {label} is a generator (it yields): ROS would never run "
                           "its body; make it a plain def that returns")
    try:
        signature = inspect.signature(handler)
    except (TypeError, ValueError):
        return True  # builtins without a signature: trust the user
    if what == "action":
        try:
            signature.bind(None, None)
            return 2
        except TypeError:
            pass
    try:
        signature.bind(None)
        return True
    except TypeError:
        pass
    if what == "timer":
        try:
            signature.bind()
            return False
        except TypeError:
            pass
    expected = {"subscribe": "the message", "service": "the request", "timer": "the timer event (or nothing)",
                "action": "the goal (and the action, to send feedback: def h(goal, action))"}[what]
    raise HandlerError(f"handler {name}{signature} for {label} must take one argument, {expected}; "
                       f"e.g. def {name}(msg): ...")
