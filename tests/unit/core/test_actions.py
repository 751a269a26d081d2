"""Actions without ROS: found in a graph and in a node's interface by their parts, and how a served goal ends."""

from __future__ import annotations

import pytest

from ipyros.core.actions import ActionCall, final_state
from ipyros.core.errors import HandlerError
from ipyros.core.graph import GraphSnapshot, actions_of, frozen
from ipyros.core.records import Interface
from ipyros.core.slots import GoalArguments, HandlerSlot, call_arity


def graph(topics: dict, publishers: dict, subscribers: dict) -> GraphSnapshot:
    return GraphSnapshot(topics=frozen(topics), publishers=frozen(publishers), subscribers=frozen(subscribers))


def test_ros1_actions_are_found_by_their_five_topics():
    parts = {f"/count/{p}": t for p, t in (("goal", "actionlib/TestActionGoal"), ("cancel", "actionlib_msgs/GoalID"),
                                           ("status", "actionlib_msgs/GoalStatusArray"),
                                           ("feedback", "actionlib/TestActionFeedback"),
                                           ("result", "actionlib/TestActionResult"))}
    snap = graph({**parts, "/other/goal": "geometry_msgs/PoseStamped"}, {"/count/goal": ("/client",)},
                 {"/count/goal": ("/server",)})
    [found] = actions_of(snap)
    assert (found.name, found.type, found.servers, found.clients) == ("/count", "actionlib/Test", ("/server",),
                                                                      ("/client",))


def test_ros2_actions_are_found_by_their_hidden_topics():
    snap = graph({"/fib/_action/feedback": "test_msgs/action/Fibonacci_FeedbackMessage",
                  "/fib/_action/status": "action_msgs/msg/GoalStatusArray"},
                 {"/fib/_action/status": ("/server",)}, {"/fib/_action/feedback": ("/client",)})
    [found] = actions_of(snap)
    assert (found.name, found.type, found.servers, found.clients) == ("/fib", "test_msgs/Fibonacci", ("/server",),
                                                                      ("/client",))


def test_a_basenodes_action_is_one_entry_of_its_interface():
    ros2 = Interface("/n", publications=[("/n/fib/_action/feedback", "test_msgs/Fibonacci_FeedbackMessage"),
                                         ("/n/fib/_action/status", "action_msgs/GoalStatusArray"), ("/out", "a/B")],
                     services=[("/n/fib/_action/send_goal", "test_msgs/Fibonacci_SendGoal")]).fold_actions()
    assert ros2.actions == [("/n/fib", "test_msgs/Fibonacci")]
    assert ros2.publications == [("/out", "a/B")] and ros2.services == []
    ros1 = Interface("/n", subscriptions=[("/count/goal", "actionlib/TestActionGoal"),
                                          ("/count/cancel", "actionlib_msgs/GoalID"), ("/in", "a/B")],
                     publications=[("/count/result", "actionlib/TestActionResult")]).fold_actions()
    assert ros1.actions == [("/count", "actionlib/Test")]
    assert ros1.subscriptions == [("/in", "a/B")] and ros1.publications == []


def test_an_action_handler_takes_the_goal_and_may_take_the_action_too():
    seen = []

    def one(goal):
        seen.append(goal)
        return "one"

    def two(goal, action):
        seen.append((goal, action.name))
        return "two"

    call = ActionCall("/fib", feedback=seen.append, cancelled=lambda: False)
    for handler, expected in ((one, "one"), (two, "two")):
        slot = HandlerSlot("n /fib", handler, seen.append, pass_argument=call_arity(handler, "action", "n /fib"))
        assert slot.run(GoalArguments(("g", call))) == (True, expected)
        assert slot.recent_messages()[-1] == "g", "%try gets the goal, not the pair"
    assert seen == ["g", ("g", "/fib")]


def test_how_a_served_goal_ends():
    assert final_state(ok=False, cancelled=True, forwarded=None) == "aborted"
    assert final_state(ok=True, cancelled=True, forwarded="succeeded") == "cancelled"
    assert final_state(ok=True, cancelled=False, forwarded="aborted") == "aborted"
    assert final_state(ok=True, cancelled=False, forwarded=None) == "succeeded"


def test_forward_without_a_basenode_says_what_to_declare():
    with pytest.raises(HandlerError, match=r"declare reuse.action\('/fib'\) on a node that wraps one"):
        ActionCall("/fib", feedback=print, cancelled=lambda: False).forward("goal")
