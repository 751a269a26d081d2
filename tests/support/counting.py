"""Counting, as an action of each ROS: what tests/both/test_actions.py sends, serves and checks.

Both ROS have a test action in a package the tests can install (ROS 1: actionlib's own
``actionlib/Test``; ROS 2: ``test_msgs/Fibonacci``), with different fields. A
:class:`Counting` says "count to N" in either: the goal holds N, the i-th feedback holds i,
the result holds how far it got. Its ``plain_send`` is a client of the ROS's own library
(actionlib, rclpy.action), as another program would be, not ipyros's.
"""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Any, Optional

PEERS = Path(__file__).resolve().parents[1] / "both" / "peers"


class Counting:
    """Count to N in one ROS's test action (see the module's docstring)."""

    type: str
    server: Path  # a basenode serving "count" (relative to its namespace)

    def goal(self, n: int) -> dict: ...
    def n_of(self, goal: Any) -> int: ...
    def feedback(self, i: int) -> dict: ...
    def i_of(self, feedback: Any) -> int: ...
    def result(self, k: int) -> dict: ...
    def k_of(self, result: Any) -> int: ...
    def result_yaml(self, k: int) -> str: ...  # a line of the result of k as %action shows it

    def plain_send(self, name: str, n: int, cancel_after: Optional[int] = None,
                   timeout: float = 30.0) -> tuple[str, int, list[int]]:
        """Send "count to n" with the ROS's own client; ``(final state, the result's count, feedbacks seen)``.
        ``cancel_after``: cancel once that many feedbacks came.

        Feedback and result travel apart (two topics; on ROS 2 a topic and a service), so the result
        may overtake the last feedbacks: the feedback a result of k stands for is waited for (5 s at most).
        """
        raise NotImplementedError


def late_feedback(seen: list[int], reached: int, timeout: float = 5.0) -> list[int]:
    """``seen`` once it holds the ``reached`` feedbacks a result of ``reached`` comes after (or the timeout);
    a goal that sent no feedback before its result (a handler that answers at once) is not waited for."""
    deadline = time.monotonic() + timeout
    while seen and len(seen) < reached and time.monotonic() < deadline:
        time.sleep(0.01)
    return list(seen)


class CountingRos1(Counting):
    type = "actionlib/Test"
    server = PEERS / "count_server_ros1.py"

    def goal(self, n): return {"goal": n}
    def n_of(self, goal): return goal.goal
    def feedback(self, i): return {"feedback": i}
    def i_of(self, feedback): return feedback.feedback
    def result(self, k): return {"result": k}
    def k_of(self, result): return result.result
    def result_yaml(self, k): return f"result: {k}"

    def plain_send(self, name, n, cancel_after=None, timeout=30.0):
        import actionlib
        import rospy
        from actionlib.msg import TestAction, TestGoal
        from actionlib_msgs.msg import GoalStatus

        # ActionClient, not SimpleActionClient: the simple one drops a feedback that comes before its
        # send_goal returns (a quick server's first), which would fail a test for a loss that is not ipyros's
        client = actionlib.ActionClient(name, TestAction)
        try:
            assert client.wait_for_server(rospy.Duration(timeout)), f"no action server {name}"
            # wait_for_server knows the server hears our goals, not that we hear its feedback and result: a quick
            # goal's first feedback would go to no one (seen once on a loaded machine)
            # Nor is our side of a connection enough: rospy counts it once the publisher's header came, a moment
            # before the publisher adds it to those it sends to (a first feedback lost so, 2 CI runs in 4): the
            # publisher is asked (getBusInfo) whom it sends to.
            deadline = time.monotonic() + timeout
            while not (_sends_to_us(f"{name}/feedback") and _sends_to_us(f"{name}/result")):
                assert time.monotonic() < deadline, f"{name}'s feedback and result never connected"
                time.sleep(0.02)
            seen: list[int] = []
            done = threading.Event()

            def feedback(handle, message):
                seen.append(message.feedback)
                if cancel_after is not None and len(seen) == cancel_after:
                    handle.cancel()

            def transition(handle):
                if handle.get_comm_state() == actionlib.CommState.DONE:
                    done.set()

            handle = client.send_goal(TestGoal(goal=n), transition_cb=transition, feedback_cb=feedback)
            assert done.wait(timeout), f"no result from {name}"
            state = {GoalStatus.SUCCEEDED: "succeeded", GoalStatus.PREEMPTED: "cancelled",
                     GoalStatus.ABORTED: "aborted"}.get(handle.get_goal_status(), str(handle.get_goal_status()))
            reached = handle.get_result().result
            return state, reached, late_feedback(seen, reached if state == "succeeded" else 0)
        finally:
            client.stop()


def _sends_to_us(topic: str) -> bool:
    """Whether every ROS 1 publisher of ``topic`` has a connection open to this process's node."""
    import rosgraph
    import rospy
    from helpers import one_call

    me = rospy.get_caller_id()
    master = rosgraph.Master(me)
    publishers = next((nodes for name, nodes in master.getSystemState()[0] if name == topic), [])
    for node in publishers:
        code, _, connections = one_call(master.lookupNode(node)).getBusInfo(me)
        if code != 1 or not any(c[1] == me and c[2] == "o" and c[4] == topic for c in connections):
            return False
    return bool(publishers)


class CountingRos2(Counting):
    type = "test_msgs/Fibonacci"
    server = PEERS / "count_server_ros2.py"

    def goal(self, n): return {"order": n}
    def n_of(self, goal): return goal.order
    def feedback(self, i): return {"sequence": list(range(i))}
    def i_of(self, feedback): return len(feedback.sequence)
    def result(self, k): return {"sequence": list(range(k))}
    def k_of(self, result): return len(result.sequence)
    def result_yaml(self, k): return f"- {k - 1}"

    def plain_send(self, name, n, cancel_after=None, timeout=30.0):
        import rclpy
        from action_msgs.msg import GoalStatus
        from rclpy.action import ActionClient
        from rclpy.executors import SingleThreadedExecutor
        from test_msgs.action import Fibonacci

        context = rclpy.Context()
        rclpy.init(context=context)
        node = rclpy.create_node("plain_action_client", context=context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        client = ActionClient(node, Fibonacci, name)
        spinner = threading.Thread(target=executor.spin, daemon=True)
        spinner.start()
        try:
            assert client.wait_for_server(timeout_sec=timeout), f"no action server {name}"
            # The server's services answer before its feedback publisher is matched with this client (discovery of
            # each endpoint apart): a quick goal's feedback would be lost, a loss of the client's, not the server's.
            deadline = time.monotonic() + timeout
            while node.count_publishers(f"{name}/_action/feedback") < 1 and time.monotonic() < deadline:
                time.sleep(0.02)
            time.sleep(0.1)  # discovered is not yet matched: the reader's side takes a moment more
            seen: list[int] = []
            for _ in range(5):  # right after discovery a server's reply can be lost (rmw waits 100 ms for our
                # reader): as ROS 2 clients do, the goal is sent again
                accepted, ended = threading.Event(), threading.Event()
                sent = client.send_goal_async(Fibonacci.Goal(order=n),
                                              feedback_callback=lambda m: seen.append(len(m.feedback.sequence)))
                sent.add_done_callback(lambda _: accepted.set())
                if accepted.wait(timeout / 5):
                    break
            assert accepted.is_set(), f"{name} did not take the goal"
            result = sent.result().get_result_async()
            result.add_done_callback(lambda _: ended.set())
            if cancel_after is not None:
                while len(seen) < cancel_after and not ended.wait(0.01):
                    pass
                sent.result().cancel_goal_async()
            assert ended.wait(timeout), f"no result from {name}"
            state = {GoalStatus.STATUS_SUCCEEDED: "succeeded", GoalStatus.STATUS_CANCELED: "cancelled",
                     GoalStatus.STATUS_ABORTED: "aborted"}.get(result.result().status, str(result.result().status))
            reached = len(result.result().result.sequence)
            return state, reached, late_feedback(seen, reached if state == "succeeded" else 0)
        finally:
            executor.shutdown()
            spinner.join(timeout=5.0)
            client.destroy()
            node.destroy_node()
            context.try_shutdown()
            context.destroy()  # its participant deleted now: else its Fast DDS ports outlive the process
