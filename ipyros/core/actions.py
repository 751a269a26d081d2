"""Actions, as both ROS have them: what a handler serving a goal gets, and what a sent goal gives back.

An action is a goal that takes time: its server sends feedback while it works, may be
asked to cancel, and ends with a result and a final state. The backends run the ROS
parts (ROS 1: actionlib's five topics; ROS 2: three services and two topics under
``<name>/_action/``); this module holds the contracts the user sees, the same on both:

- a handler serving an action is ``handler(goal)`` or ``handler(goal, action)``, where
  ``action`` is an :class:`ActionCall`: ``action.feedback(msg)`` sends feedback,
  ``action.cancelled`` says whether the client asked to cancel, and, on a node that
  intercepts its basenode's action, ``action.forward(goal)`` sends a goal (changed or not)
  to the basenode's own server and returns its result, passing its feedback on. The
  handler returns the result (a message, a dict of its fields, or None for an empty one);
  a handler that returns after a cancel ends the goal as cancelled, one that raises
  aborts it (reported like any handler error);
- ``nd.send_goal(...)`` returns a :class:`SentGoal`: ``result(timeout)``, ``cancel()``,
  ``status``, ``feedback`` (the last one).
"""

from __future__ import annotations

import threading
from typing import Any, Callable, Optional, Protocol

from .errors import HandlerError, IpyrosError
from .msgbuild import build_message, conform
from .slots import GoalArguments, HandlerSlot

__all__ = ["ActionCall", "GOAL_STATES", "GoalResult", "SentGoal", "Waiter", "final_state", "serve_goal", "to_message"]

#: The final states of a goal, as both ROS name them (actionlib's and action_msgs' GoalStatus).
GOAL_STATES = ("succeeded", "cancelled", "aborted", "rejected")


class ActionCall:
    """One goal being served: the second argument of an action handler."""

    def __init__(self, name: str, feedback: Callable[[Any], None], cancelled: Callable[[], bool],
                 forward: Optional[Callable[[Any, Callable[[], bool], Callable[[Any], None]], Any]] = None) -> None:
        self.name = name
        self._feedback, self._cancelled, self._forward = feedback, cancelled, forward
        self.forwarded: Optional[str] = None  # the final state of the forwarded goal, once forward() returned

    def feedback(self, msg: Any) -> None:
        """Send feedback to the client: a Feedback message, or a dict of its fields."""
        self._feedback(msg)

    @property
    def cancelled(self) -> bool:
        """True once the client asked to cancel: end the work and return (the goal ends cancelled)."""
        return self._cancelled()

    def forward(self, goal: Any) -> Any:
        """Send ``goal`` to the basenode's own server; its feedback goes on to the client; returns its result.

        A cancel from the client is passed on to the basenode while it works.
        """
        if self._forward is None:
            raise HandlerError(f"{self.name}: forward() needs a basenode's action to forward to; declare "
                               f"reuse.action({self.name!r}) on a node that wraps one")
        state, result = self._forward(goal, self._cancelled, self._feedback)
        self.forwarded = state
        return result

    def __repr__(self) -> str:
        return f"<goal of {self.name}{' (cancel asked)' if self.cancelled else ''}>"


class SentGoal(Protocol):
    """A goal this session sent (``nd.send_goal``, ``%action``)."""

    name: str

    @property
    def status(self) -> str: ...  # "pending", "active", then one of GOAL_STATES

    @property
    def feedback(self) -> Any: ...  # the last feedback message, None before any

    def result(self, timeout: Optional[float] = None) -> Any: ...

    def cancel(self, timeout: float = 5.0) -> bool: ...

    def done(self) -> bool: ...


def final_state(ok: bool, cancelled: bool, forwarded: Optional[str]) -> str:
    """How a served goal ends: aborted when the handler raised, as the forwarded goal ended when it
    forwarded one and was not cancelled, cancelled when a cancel came, else succeeded."""
    if not ok:
        return "aborted"
    if cancelled:
        return "cancelled"
    if forwarded in ("aborted", "rejected"):
        return "aborted"
    return "succeeded"


def to_message(cls: type, value: Any, what: str) -> Any:
    """A message of ``cls`` from what a handler gave: the message (checked), a dict of its fields, or None."""
    if value is None:
        return cls()
    if isinstance(value, cls):
        return conform(value)
    if isinstance(value, (dict, list, str)):
        return build_message(cls, value)
    raise IpyrosError(f"{what} is a {type(value).__name__}, not a {cls.__name__}; give the message or a dict of "
                      "its fields")


def serve_goal(slot: HandlerSlot, goal: Any, call: ActionCall, result_cls: type) -> tuple[str, Any]:
    """Run an action's handler on one goal: how the goal ends (see :func:`final_state`) and its result.

    The handler's exception, or a result that is no ``result_cls``, is reported once through the
    slot (counted in ``%status``) and aborts the goal with an empty result.
    """
    ok, value = slot.run(GoalArguments((goal, call)))
    result = result_cls()
    if ok:
        try:
            result = to_message(result_cls, value, f"the result of the handler of {call.name}")
        except IpyrosError as error:
            slot.fail(error)
            ok = False
    return final_state(ok, call.cancelled, call.forwarded), result


class GoalResult:
    """The waiting half of a sent goal: the result once it came (the backends' goals build on it)."""

    name: str
    status: str

    def __init__(self) -> None:
        self._result = Waiter()

    def done(self) -> bool:
        return self._result.is_set()

    def wait(self, timeout: Optional[float] = None) -> bool:
        """Wait up to ``timeout`` s for the goal to end; True if it has."""
        return self._result.wait(timeout)

    def result(self, timeout: Optional[float] = None) -> Any:
        """The result, once the goal has ended (waits up to ``timeout`` s; None: as long as it takes)."""
        if not self._result.wait(timeout):
            raise TimeoutError(f"{self.name}: no result within {timeout:g} s (the goal is {self.status})")
        return self._result.value

    def __repr__(self) -> str:
        return f"<goal {self.name}: {self.status}>"


class Waiter:
    """A value that one thread sets once and others wait for (the backends' futures are not all thread-friendly)."""

    def __init__(self) -> None:
        self._done = threading.Event()
        self.value: Any = None

    def set(self, value: Any) -> None:
        if not self._done.is_set():
            self.value = value
            self._done.set()

    def wait(self, timeout: Optional[float] = None) -> bool:
        return self._done.wait(timeout)

    def is_set(self) -> bool:
        return self._done.is_set()
