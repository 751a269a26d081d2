"""rclpy actions: a server whose goals run on threads of their own, a client, and a relay of a basenode's action.

A ROS 2 action is three services and two topics under ``<name>/_action/``:
``send_goal``, ``cancel_goal`` and ``get_result``; ``feedback`` and ``status``. rclpy's
:class:`rclpy.action.ActionServer` runs a goal's execute callback on the executor; a
handler that works for seconds would hold up every subscription of the session, so the
callback here only awaits a future that the goal's own thread completes (an rclpy task
yields while it waits). A relay relays the five parts as one unit: the services through
:class:`~ipyros.ros2.endpoints.ServiceRelay` (``get_result`` without a time limit: it is
answered when the goal ends), the topics as bytes through :class:`~ipyros.ros2.endpoints.Relay`.
"""

from __future__ import annotations

import threading
import time
import uuid
from typing import Any, Callable, Optional

from action_msgs.msg import GoalStatus, GoalStatusArray
from action_msgs.srv import CancelGoal
from rclpy.action import ActionClient, ActionServer as RclpyActionServer, CancelResponse, GoalResponse
from rclpy.node import Node
from rclpy.qos import qos_profile_action_status_default
from rclpy.task import Future

from ..core.actions import ActionCall, GoalResult, Waiter, serve_goal, to_message
from ..core.errors import IpyrosError
from ..core.slots import HandlerSlot
from .endpoints import RESULT_SETTLE, Relay, ServiceRelay
from .qosmatch import Complain
from .runtime import ProcessNode

__all__ = ["ActionRelay", "ActionServer", "ActionWatch", "Goal", "Goals", "STATES"]

#: action_msgs/GoalStatus codes by the names the session uses.
STATES = {GoalStatus.STATUS_UNKNOWN: "pending", GoalStatus.STATUS_ACCEPTED: "active",
          GoalStatus.STATUS_EXECUTING: "active", GoalStatus.STATUS_CANCELING: "cancelling",
          GoalStatus.STATUS_SUCCEEDED: "succeeded", GoalStatus.STATUS_CANCELED: "cancelled",
          GoalStatus.STATUS_ABORTED: "aborted"}

#: How long a goal sent may wait for the server to show up and to accept it (s).
ACCEPT_TIMEOUT = 10.0
#: How long a new client waits, once it sees its server, for the server to see it (s): discovery is two ways.
SETTLE = 0.5


class Goals:
    """Goals sent from one node (the session's caller node): one rclpy client per action name, kept."""

    def __init__(self, node: Node) -> None:
        self._node = node
        self._clients: dict[tuple[str, type], ActionClient] = {}
        self._settled: set[ActionClient] = set()  # clients whose server has had its moment to see them
        self._lock = threading.Lock()

    def client(self, name: str, cls: type) -> ActionClient:
        with self._lock:
            client = self._clients.get((name, cls))
            if client is None:
                client = self._clients[(name, cls)] = ActionClient(self._node, cls, name)
            return client

    def send(self, name: str, cls: type, goal: Any, feedback: Optional[Callable[[Any], None]] = None,
             timeout: float = ACCEPT_TIMEOUT) -> "Goal":
        client = self.client(name, cls)
        if not client.wait_for_server(timeout_sec=timeout):
            raise IpyrosError(f"no action server {name} answered within {timeout:g} s; see %actions for the "
                              "servers there are")
        with self._lock:
            settled = client in self._settled
            self._settled.add(client)
        if not settled:
            # We see the server; it may not see us yet, and a server sends its answer only to a client it has
            # matched (rmw waits 100 ms for that): a goal sent at once could be taken and its answer lost.
            time.sleep(SETTLE)
        return Goal(name, cls, client, to_message(cls.Goal, goal, f"the goal of {name}"), feedback, timeout)

    def close(self) -> None:
        with self._lock:
            for client in self._clients.values():
                client.destroy()
            self._clients.clear()


class Goal(GoalResult):
    """A goal sent to an action server (see :class:`ipyros.core.actions.SentGoal`)."""

    def __init__(self, name: str, cls: type, client: ActionClient, goal: Any,
                 feedback: Optional[Callable[[Any], None]], timeout: float) -> None:
        super().__init__()
        self.name, self.goal = name, goal
        self._feedback_fn, self.feedback = feedback, None
        self._status = "pending"
        self._handle: Any = None
        accepted = Waiter()
        sent = client.send_goal_async(goal, feedback_callback=self._on_feedback)
        sent.add_done_callback(lambda done: accepted.set(done.result()))
        if not accepted.wait(timeout):
            raise IpyrosError(f"{name}: no answer to the goal within {timeout:g} s; the server may be busy, or have "
                              f"taken it without its answer reaching here (%action --watch {name} shows its goals)")
        self._handle = accepted.value
        if not self._handle.accepted:
            self._status = "rejected"
            self._result.set(None)
            return
        self._status = "active"
        self._handle.get_result_async().add_done_callback(self._on_result)

    def _on_feedback(self, message: Any) -> None:
        self.feedback = message.feedback
        if self._feedback_fn is not None:
            self._feedback_fn(message.feedback)

    def _on_result(self, done: Any) -> None:
        response = done.result()
        self._status = STATES.get(response.status, "aborted")
        self._result.set(response.result)

    @property
    def status(self) -> str:
        return self._status

    def cancel(self, timeout: float = 5.0) -> bool:
        """Ask the server to cancel; True once it accepted the cancel (the goal then ends cancelled)."""
        if self._handle is None or self.done():
            return False
        answered = Waiter()
        self._handle.cancel_goal_async().add_done_callback(lambda done: answered.set(done.result()))
        if not answered.wait(timeout):
            return False
        return answered.value.return_code == CancelGoal.Response.ERROR_NONE


class ActionServer:
    """Serve action ``name``: each goal goes to ``slot`` on a thread of its own.

    ``forward`` is the basenode's own server (its internal name), when the node intercepts
    a wrapped action: the handler's ``action.forward(goal)`` sends the goal there.
    """

    def __init__(self, process: ProcessNode, node: Node, name: str, cls: type, slot: HandlerSlot,
                 forward: Optional[str] = None) -> None:
        self.name, self.cls, self.slot = name, cls, slot
        self._node = node
        self._goals = Goals(process.caller()) if forward else None
        self._forward_to = forward
        self._server = RclpyActionServer(node, cls, name, execute_callback=self._execute,
                                         goal_callback=lambda goal: GoalResponse.ACCEPT,
                                         cancel_callback=lambda handle: CancelResponse.ACCEPT)

    async def _execute(self, handle: Any) -> Any:
        done = Future(executor=self._node.executor)
        worker = threading.Thread(target=self._work, args=(handle, done), daemon=True,
                                  name=f"ipyros-goal-{self.name}-{_goal_id(handle.goal_id)}")
        worker.start()
        return await done

    def _work(self, handle: Any, done: Future) -> None:
        call = ActionCall(self.name, lambda msg: handle.publish_feedback(to_message(self.cls.Feedback, msg,
                                                                                    "feedback")),
                          lambda: handle.is_cancel_requested, self._forward if self._goals else None)
        state, result = serve_goal(self.slot, handle.request, call, self.cls.Result)
        try:
            {"aborted": handle.abort, "cancelled": handle.canceled}.get(state, handle.succeed)()
        except Exception:  # noqa: BLE001 - the goal's state moved on meanwhile (server closing)
            pass
        done.set_result(result)

    def _forward(self, goal: Any, cancelled: Callable[[], bool], feedback: Callable[[Any], None]) -> tuple[str, Any]:
        assert self._goals is not None and self._forward_to is not None
        sent = self._goals.send(self._forward_to, self.cls, goal, feedback)
        asked = False
        while not sent.done():
            if cancelled() and not asked:
                asked = True
                sent.cancel()
            sent.wait(0.05)
        return sent.status, sent.result()

    def close(self) -> None:
        self._server.destroy()
        if self._goals is not None:
            self._goals.close()


class ActionRelay:
    """Relay action ``source`` (the basenode's, remapped) as ``target``, all five parts, as one unit."""

    def __init__(self, process: ProcessNode, node: Node, source: str, target: str, cls: type,
                 on_wrong_type: Optional[Callable[[str], None]] = None, complain: Optional[Complain] = None) -> None:
        self.source, self.target, self.cls = source, target, cls
        parts: list[Any] = []
        try:
            for part, service, timeout in (("send_goal", cls.Impl.SendGoalService, ServiceRelay.TIMEOUT),
                                           ("cancel_goal", CancelGoal, ServiceRelay.TIMEOUT),
                                           ("get_result", cls.Impl.GetResultService, None)):
                parts.append(ServiceRelay(process, node, f"{source}/_action/{part}", f"{target}/_action/{part}",
                                          service, complain, timeout,
                                          settle=RESULT_SETTLE if part == "get_result" else 0.0))
            # Feedback and status are read on the caller node, whose one thread also takes the basenode's
            # results: a goal's last feedback is passed on before its result (an rclpy client drops
            # feedback that comes after the result, and a busy session thread could delay it that long).
            for part, message in (("feedback", cls.Impl.FeedbackMessage), ("status", GoalStatusArray)):
                parts.append(Relay(process, node, f"{source}/_action/{part}", f"{target}/_action/{part}", message,
                                   on_wrong_type, complain, reader=process.caller()))
        except BaseException:
            for opened in parts:
                opened.close()
            raise
        self._parts = parts

    def close(self) -> None:
        for part in self._parts:
            part.close()


class ActionWatch:
    """What a ROS 2 graph shows of action ``name``'s goals: their status changes and feedback.

    ``tell(event, goal_id, message)``: ``("goal", id, None)`` when a goal shows up,
    ``("feedback", id, feedback)``, and the goal's state (``"active"``, ``"succeeded"``, ...)
    as it changes. Goals and results themselves travel by service on ROS 2, which only
    the two ends see.
    """

    def __init__(self, node: Node, name: str, cls: type, tell: Callable[[str, str, Any], None]) -> None:
        self._node, self._tell = node, tell
        self._states: dict[str, str] = {}
        self._subscriptions = [
            node.create_subscription(cls.Impl.FeedbackMessage, f"{name}/_action/feedback",
                                     lambda m: tell("feedback", _goal_id(m.goal_id), m.feedback), 10),
            node.create_subscription(GoalStatusArray, f"{name}/_action/status", self._status,
                                     qos_profile_action_status_default)]

    def _status(self, message: Any) -> None:
        for status in message.status_list:
            goal_id, state = _goal_id(status.goal_info.goal_id), STATES.get(status.status, "pending")
            if goal_id not in self._states:
                self._tell("goal", goal_id, None)
            if self._states.get(goal_id) != state:
                self._states[goal_id] = state
                self._tell(state, goal_id, None)

    def close(self) -> None:
        for subscription in self._subscriptions:
            self._node.destroy_subscription(subscription)


def _goal_id(uuid_msg: Any) -> str:
    return uuid.UUID(bytes=bytes(uuid_msg.uuid)).hex[:8]
