"""actionlib actions: a server whose goals run on threads of their own, a client, and a relay of a basenode's action.

A ROS 1 action is five topics under its name: ``goal`` and ``cancel`` go to the server,
``status``, ``feedback`` and ``result`` come from it (``pkg/TypeActionGoal``,
``actionlib_msgs/GoalID``, ``actionlib_msgs/GoalStatusArray``, ``pkg/TypeActionFeedback``,
``pkg/TypeActionResult``). A relay is five byte relays (:class:`~ipyros.ros1.endpoints.Relay`),
one unit; a basenode is remapped topic by topic (the backend's ``action_parts``), since ROS 1
remaps names, not namespaces.
"""

from __future__ import annotations

import importlib
import threading
import time
from typing import Any, Callable, Optional

import actionlib
import rospy
from actionlib_msgs.msg import GoalID, GoalStatus, GoalStatusArray

from ..core import msgtypes
from ..core.actions import ActionCall, GoalResult, serve_goal, to_message
from ..core.errors import IpyrosError
from ..core.slots import HandlerSlot
from .endpoints import Relay

__all__ = ["ActionRelay", "ActionServer", "ActionWatch", "Goal", "Goals", "STATES"]

#: actionlib_msgs/GoalStatus codes by the names the session uses (a recalled goal was cancelled before it started).
STATES = {GoalStatus.PENDING: "pending", GoalStatus.ACTIVE: "active", GoalStatus.PREEMPTING: "cancelling",
          GoalStatus.RECALLING: "cancelling", GoalStatus.SUCCEEDED: "succeeded", GoalStatus.PREEMPTED: "cancelled",
          GoalStatus.RECALLED: "cancelled", GoalStatus.ABORTED: "aborted", GoalStatus.REJECTED: "rejected",
          GoalStatus.LOST: "aborted"}

#: How long a goal sent may wait for the server to show up (s).
ACCEPT_TIMEOUT = 10.0


def _parts(cls: type) -> dict[str, type]:
    """The message classes of an action's ``XAction`` class: Goal, Result, Feedback and their Action* envelopes."""
    goal, result, feedback = msgtypes.action_messages(cls)
    module = importlib.import_module(cls.__module__.split(".")[0] + ".msg")
    stem = cls.__name__.removesuffix("Action")
    envelopes = {part: getattr(module, stem + part) for part in ("ActionGoal", "ActionFeedback", "ActionResult")}
    return {"Goal": goal, "Result": result, "Feedback": feedback, **envelopes}


class Goals:
    """Goals sent from the session: one actionlib client per action name, kept."""

    def __init__(self) -> None:
        self._clients: dict[tuple[str, type], actionlib.ActionClient] = {}
        self._lock = threading.Lock()

    def send(self, name: str, cls: type, goal: Any, feedback: Optional[Callable[[Any], None]] = None,
             timeout: float = ACCEPT_TIMEOUT) -> "Goal":
        with self._lock:
            client = self._clients.get((name, cls))
            if client is None:
                client = self._clients[(name, cls)] = actionlib.ActionClient(name, cls)
        if not client.wait_for_server(rospy.Duration(timeout)):
            raise IpyrosError(f"no action server {name} answered within {timeout:g} s; see %actions for the "
                              "servers there are")
        return Goal(name, client, to_message(_parts(cls)["Goal"], goal, f"the goal of {name}"), feedback)

    def close(self) -> None:
        with self._lock:
            for client in self._clients.values():
                client.stop()
            self._clients.clear()


class Goal(GoalResult):
    """A goal sent to an action server (see :class:`ipyros.core.actions.SentGoal`)."""

    def __init__(self, name: str, client: actionlib.ActionClient, goal: Any,
                 feedback: Optional[Callable[[Any], None]]) -> None:
        super().__init__()
        self.name, self.goal = name, goal
        self._feedback_fn, self.feedback = feedback, None
        self._handle = None
        self._handle = client.send_goal(goal, transition_cb=self._on_transition, feedback_cb=self._on_feedback)

    def _on_feedback(self, handle: Any, feedback: Any) -> None:
        self.feedback = feedback
        if self._feedback_fn is not None:
            self._feedback_fn(feedback)

    def _on_transition(self, handle: Any) -> None:
        if handle.get_comm_state() == actionlib.CommState.DONE:
            self._result.set(handle.get_result())

    @property
    def status(self) -> str:
        if self._handle is None:  # actionlib calls back before send_goal returns
            return "pending"
        return STATES.get(self._handle.get_goal_status(), "pending")

    def cancel(self, timeout: float = 5.0) -> bool:
        """Ask the server to cancel; True once it took the cancel (the goal is cancelling or ended cancelled)."""
        if self.done():
            return False
        self._handle.cancel()  # actionlib does not answer a cancel: the goal's status tells
        deadline = time.monotonic() + timeout
        while self.status not in ("cancelling", "cancelled") and not self.done() and time.monotonic() < deadline:
            self._result.wait(0.05)
        return self.status in ("cancelling", "cancelled")


class ActionServer:
    """Serve action ``name``: each goal goes to ``slot`` on a thread of its own.

    ``forward`` is the basenode's own server (its internal name), when the node intercepts
    a wrapped action: the handler's ``action.forward(goal)`` sends the goal there.
    """

    def __init__(self, name: str, cls: type, slot: HandlerSlot, forward: Optional[str] = None) -> None:
        self.name, self.cls, self.slot = name, cls, slot
        self._parts = _parts(cls)
        self._goals = Goals() if forward else None
        self._forward_to = forward
        self._cancelled: dict[str, threading.Event] = {}
        self._server = actionlib.ActionServer(name, cls, self._on_goal, self._on_cancel, auto_start=False)
        self._server.start()

    def _on_goal(self, handle: Any) -> None:
        goal_id = handle.get_goal_id().id
        self._cancelled[goal_id] = threading.Event()
        handle.set_accepted()
        threading.Thread(target=self._work, args=(handle, goal_id), daemon=True,
                         name=f"ipyros-goal-{self.name}").start()

    def _on_cancel(self, handle: Any) -> None:
        cancelled = self._cancelled.get(handle.get_goal_id().id)
        if cancelled is not None:
            cancelled.set()

    def _work(self, handle: Any, goal_id: str) -> None:
        cancelled = self._cancelled[goal_id]
        call = ActionCall(self.name, lambda msg: handle.publish_feedback(to_message(self._parts["Feedback"], msg,
                                                                                    "feedback")),
                          cancelled.is_set, self._forward if self._goals else None)
        state, result = serve_goal(self.slot, handle.get_goal(), call, self._parts["Result"])
        self._cancelled.pop(goal_id, None)
        try:
            {"aborted": handle.set_aborted, "cancelled": handle.set_canceled}.get(state, handle.set_succeeded)(result)
        except Exception:  # noqa: BLE001 - the server was stopped meanwhile
            pass

    def _forward(self, goal: Any, cancelled: Callable[[], bool], feedback: Callable[[Any], None]) -> tuple[str, Any]:
        assert self._goals is not None and self._forward_to is not None
        sent = self._goals.send(self._forward_to, self.cls, goal, feedback)
        asked = False
        while not sent.wait(0.05):
            if cancelled() and not asked:
                asked = True
                sent.cancel(timeout=0)
        return sent.status, sent.result()

    def close(self) -> None:
        self._server.stop()
        if self._goals is not None:
            self._goals.close()


class _StatusRelay(Relay):
    """An action's status relay: it forwards only while ``ready()`` says the rest of the relay is connected.

    A client takes the server's status as "the server is there" (actionlib's ``wait_for_server``)
    and sends its goal at once; a goal that comes before the relay's goal topic is connected to
    the basenode is lost, and the client waits for its result forever. The server repeats its
    status (5 Hz), so holding it back until then loses nothing.
    """

    def __init__(self, source: str, target: str, ready: Callable[[], bool],
                 on_wrong_type: Optional[Callable[[str], None]],
                 complain: Optional[Callable[[str], None]]) -> None:
        self._ready = ready  # before the subscription: a message may come at once
        super().__init__(source, target, GoalStatusArray, on_wrong_type, complain)

    def _forward(self, raw: rospy.AnyMsg) -> None:
        if self._ready():
            super()._forward(raw)


class ActionRelay:
    """Relay action ``source`` (the basenode's, remapped) as ``target``: its five topics, as bytes, as one unit."""

    def __init__(self, source: str, target: str, cls: type,
                 on_wrong_type: Optional[Callable[[str], None]] = None,
                 complain: Optional[Callable[[str], None]] = None) -> None:
        self.source, self.target, self.cls = source, target, cls
        parts = _parts(cls)
        self._inward: list[Relay] = []
        self._outward: list[Relay] = []
        try:
            for part, message in (("goal", parts["ActionGoal"]), ("cancel", GoalID)):
                self._inward.append(Relay(f"{target}/{part}", f"{source}/{part}", message, on_wrong_type, complain))
            for part, message in (("feedback", parts["ActionFeedback"]), ("result", parts["ActionResult"])):
                self._outward.append(Relay(f"{source}/{part}", f"{target}/{part}", message, on_wrong_type, complain))
            self._outward.append(_StatusRelay(f"{source}/status", f"{target}/status", self._connected,
                                              on_wrong_type, complain))
        except BaseException:
            self.close()
            raise

    def _connected(self) -> bool:
        """Whether goals and cancels reach the basenode and its feedback and results come back."""
        return (all(relay.peers()[1] for relay in self._inward)
                and all(relay.peers()[0] for relay in self._outward))

    def close(self) -> None:
        for relay in self._inward + self._outward:
            relay.close()


class ActionWatch:
    """What the ROS 1 graph shows of action ``name``'s goals: each goal, its feedback and its result.

    ``tell(event, goal_id, message)``: ``("goal", id, goal)``, ``("feedback", id, feedback)``,
    then the final state (``"succeeded"``, ``"cancelled"``, ...) with the result.
    """

    def __init__(self, name: str, cls: type, tell: Callable[[str, str, Any], None]) -> None:
        parts = _parts(cls)
        self._subscribers = [
            rospy.Subscriber(f"{name}/goal", parts["ActionGoal"],
                             lambda m: tell("goal", m.goal_id.id, m.goal)),
            rospy.Subscriber(f"{name}/feedback", parts["ActionFeedback"],
                             lambda m: tell("feedback", m.status.goal_id.id, m.feedback)),
            rospy.Subscriber(f"{name}/result", parts["ActionResult"],
                             lambda m: tell(STATES.get(m.status.status, "aborted"), m.status.goal_id.id, m.result))]

    def close(self) -> None:
        for subscriber in self._subscribers:
            subscriber.unregister()
