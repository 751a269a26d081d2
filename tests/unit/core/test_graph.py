"""The graph as plain data: prefix and pattern queries, and actions found by their parts
(:mod:`ipyros.core.graph`)."""

from __future__ import annotations

import pytest

from ipyros.core import graph


def snapshot(**fields):
    return graph.GraphSnapshot(**{k: graph.frozen(v) if isinstance(v, dict) else v for k, v in fields.items()})


SNAP = snapshot(topics={"/turtle1/pose": "turtlesim/Pose", "/turtle1/cmd_vel": "geometry_msgs/Twist",
                        "/turtle2/pose": "turtlesim/msg/Pose", "/rosout": "rosgraph_msgs/Log"},
                publishers={"/turtle1/pose": ("/sim",), "/rosout": ("/sim", "/teleop")},
                subscribers={"/turtle1/cmd_vel": ("/sim",)}, nodes=("/sim", "/teleop"), master_up=True)


def test_topics_and_nodes_by_prefix_sorted():
    assert SNAP.topics_with_prefix("/turtle1/") == ["/turtle1/cmd_vel", "/turtle1/pose"]
    assert SNAP.topics_with_prefix("/nothing") == []
    assert SNAP.nodes_with_prefix("/t") == ["/teleop"]
    assert SNAP.topic_names == tuple(sorted(SNAP.topics))


def test_topics_matching_a_glob_a_substring_a_type_and_a_node():
    assert SNAP.topics_matching("/turtle*/pose") == ["/turtle1/pose", "/turtle2/pose"]
    assert SNAP.topics_matching("cmd") == ["/turtle1/cmd_vel"]
    assert SNAP.topics_matching(type="turtlesim/Pose") == ["/turtle1/pose", "/turtle2/pose"]  # both spellings
    assert SNAP.topics_matching(type="geometry_msgs/*") == ["/turtle1/cmd_vel"]
    assert SNAP.topics_matching(node="/sim") == ["/rosout", "/turtle1/cmd_vel", "/turtle1/pose"]
    assert SNAP.topics_matching("pose", node="/teleop") == []


def test_the_empty_graph():
    assert graph.EMPTY.topic_names == () and not graph.EMPTY.master_up


def test_names_with_prefix_bisects_a_sorted_list():
    names = sorted(f"/t{i:04d}" for i in range(1000))
    assert graph.names_with_prefix(names, "/t099") == [f"/t099{i}" for i in range(10)]


def test_ros1_actions_are_found_by_their_five_topics():
    parts = {f"/move/{p}": f"nav_msgs/Move{p.capitalize()}" for p in graph.ROS1_ACTION_TOPICS}
    parts["/move/goal"] = "nav_msgs/MoveActionGoal"
    snap = snapshot(topics=parts, subscribers={"/move/goal": ("/server",)}, publishers={"/move/goal": ("/client",)})
    (found,) = graph.actions_of(snap)
    assert (found.name, found.type, found.servers, found.clients) == ("/move", "nav_msgs/Move", ("/server",),
                                                                      ("/client",))


def test_ros2_actions_are_found_by_their_feedback_topic():
    snap = snapshot(topics={"/fib/_action/feedback": "test_msgs/action/Fibonacci_FeedbackMessage",
                            "/fib/_action/status": "action_msgs/msg/GoalStatusArray"},
                    publishers={"/fib/_action/status": ("/server",)}, subscribers={"/fib/_action/feedback": ("/c",)})
    (found,) = graph.actions_of(snap)
    assert (found.name, found.type, found.servers, found.clients) == ("/fib", "test_msgs/Fibonacci", ("/server",),
                                                                      ("/c",))


class _Clock:
    """A clock of the test's: each sleep moves it on."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.now += seconds


def test_a_node_is_settled_once_its_interface_stays_the_same_for_the_settle_time():
    from ipyros.core.errors import BaseNodeError
    from ipyros.core.graph import settled

    clock = _Clock()
    reads = iter([None, None, ("/a",), ("/a", "/b")])  # registering its topics one by one, then the same
    found = settled(lambda: next(reads, ("/a", "/b")), "/n", timeout=10, settle=0.5, clock=clock, sleep=clock.sleep)
    assert found == ("/a", "/b") and 0.5 <= clock.now <= 0.75, clock.now
    clock = _Clock()
    assert settled(lambda: None, "/n", timeout=2, clock=clock, sleep=clock.sleep) is None and clock.now >= 2
    clock = _Clock()
    changing = iter(range(1000))
    assert settled(lambda: (next(changing),), "/n", timeout=1, clock=clock, sleep=clock.sleep)[0] >= 20, \
        "still changing at the timeout: what it is then"
    clock = _Clock()
    with pytest.raises(BaseNodeError, match="node /n ended before it settled"):
        settled(lambda: None, "/n", alive=lambda: clock.now < 0.2, clock=clock, sleep=clock.sleep)
    assert clock.now < 0.5, "not waited for once its process ended"
