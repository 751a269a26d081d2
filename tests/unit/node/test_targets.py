"""What a name is on a node when its handler is asked for (:mod:`ipyros.node.targets`): pure over the model."""

from __future__ import annotations

import pytest

from ipyros.core import names
from ipyros.core.errors import NotDeclaredError
from ipyros.core.model import ActionModel, NodeModel, ServiceModel, TimerModel, TopicModel
from ipyros.node.targets import HandlerTarget, find_target, handler_slots, relayed_target

MODEL = NodeModel("ctl", "/", topics=[
    TopicModel("pose", "/pose", "subscribe", "turtlesim/Pose", "new", "on_pose"),
    TopicModel("cmd", "/cmd", "publish", "geometry_msgs/Twist", "reuse"),
    TopicModel("scan", "/scan", "publish", "sensor_msgs/LaserScan", "reuse"),
    TopicModel("scan", "/scan", "subscribe", "sensor_msgs/LaserScan", "new", "on_scan"),
], timers=[TimerModel("tick", 1.0, "tick")], services=[ServiceModel("reset", "/reset", "std_srvs/Empty", "new", "r")],
    actions=[ActionModel("fib", "/fib", "test_msgs/Fibonacci", "new", "fib")])


def resolve(name: str, kind: str = "topic") -> str:
    return names.resolve(name, "/", "ctl", kind)


@pytest.mark.parametrize("name, target", [
    ("pose", HandlerTarget("topic", "pose", "topic /pose")),
    ("/pose", HandlerTarget("topic", "pose", "topic /pose")),
    ("tick", HandlerTarget("timer", "tick", "timer tick")),
    ("reset", HandlerTarget("service", "reset", "service /reset")),
    ("fib", HandlerTarget("action", "fib", "action /fib")),
])
def test_a_name_is_what_serves_it(name, target):
    assert find_target(MODEL, resolve, name, "nd") == target


def test_a_relayed_topic_has_no_handler_to_edit_and_the_error_says_how_to_declare_one():
    with pytest.raises(NotDeclaredError) as caught:
        find_target(MODEL, resolve, "cmd", "nd")
    assert "relays /cmd unchanged (reuse)" in str(caught.value)
    assert "nd.new.subscribe('cmd', handler, msgType='geometry_msgs/Twist')" in str(caught.value)


def test_a_name_the_node_does_not_have_lists_its_handlers():
    with pytest.raises(NotDeclaredError) as caught:
        find_target(MODEL, resolve, "/nothing", "nd")
    text = str(caught.value)
    assert "ctl has no handler for /nothing; its handlers: /pose (on_pose)" in text and "timer tick (tick)" in text
    empty = NodeModel("bare")
    with pytest.raises(NotDeclaredError, match="it has no handlers yet: declare one, e.g. nd.new.subscribe"):
        find_target(empty, resolve, "x", "nd")


def test_a_relayed_topic_a_handler_may_take_over():
    assert relayed_target(MODEL, resolve, "cmd") == HandlerTarget("relay", "cmd", "topic /cmd")
    assert relayed_target(MODEL, resolve, "scan") is None  # intercepted already
    assert relayed_target(MODEL, resolve, "pose") is None and relayed_target(MODEL, resolve, "a b") is None


def test_the_slots_a_handler_of_a_name_may_be_under():
    assert handler_slots(resolve, "tick") == ("topic /tick", "service /tick", "action /tick", "timer tick")
    assert handler_slots(resolve, "<lambda>") == ("timer <lambda>",)
