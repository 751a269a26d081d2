"""The node model as plain data: what save writes and load reads, the same on both ROS."""

from __future__ import annotations

import json

import pytest
import yaml

from ipyros.core.model import ActionModel, BaseModel, NodeModel, ServiceModel, TimerModel, TopicModel


def full_model() -> NodeModel:
    return NodeModel(
        name="mb_wrapper", namespace="/robot1/",
        base=BaseModel("move_base", "ipyros_demo", "move_base", "/robot1/", {"odom": "/odom"}, {"rate": 5.0}, ["-v"]),
        topics=[TopicModel("cmd_vel", "/robot1/cmd_vel", "publish", "geometry_msgs/Twist", "reuse"),
                TopicModel("cmd_vel", "/robot1/cmd_vel", "subscribe", "geometry_msgs/Twist", "new", "clamp",
                           qos={"depth": 5, "reliability": "best_effort"})],
        timers=[TimerModel("tick", 0.1, "tick", oneshot=False)],
        services=[ServiceModel("~reset", "/robot1/mb_wrapper/reset", "std_srvs/Empty", "new", "reset")],
        params={"gain": 2.5, "names": ["a", "b"], "nested": {"k": True}},
        actions=[ActionModel("navigate", "/robot1/navigate", "nav2_msgs/NavigateToPose", "reuse"),
                 ActionModel("navigate", "/robot1/navigate", "nav2_msgs/NavigateToPose", "new", "clamp_goal")],
    )


def test_round_trip_through_a_dict():
    model = full_model()
    assert NodeModel.from_dict(model.to_dict()) == model


@pytest.mark.parametrize("dump, load", [(json.dumps, json.loads), (yaml.safe_dump, yaml.safe_load)])
def test_round_trip_through_json_and_yaml(dump, load):
    model = full_model()
    assert NodeModel.from_dict(load(dump(model.to_dict()))) == model


def test_the_dict_holds_only_plain_data():
    def plain(value):
        if isinstance(value, dict):
            return all(isinstance(k, str) and plain(v) for k, v in value.items())
        if isinstance(value, list):
            return all(plain(v) for v in value)
        return value is None or isinstance(value, (str, int, float, bool))

    assert plain(full_model().to_dict())


@pytest.mark.parametrize("where, data", [
    ("top", {"name": "x", "colour": "red"}),
    ("topic", {"name": "x", "topics": [{"name": "a", "resolved": "/a", "direction": "publish", "type": "t/T",
                                        "handler_code": "x"}]}),
    ("base", {"name": "x", "base": {"executable": "e", "shell": "/bin/sh"}}),
])
def test_unknown_keys_are_errors_not_dropped(where, data):
    with pytest.raises(ValueError, match="unknown"):
        NodeModel.from_dict(data)


def test_queries():
    model = full_model()
    assert model.topic("/robot1/cmd_vel", "subscribe").handler == "clamp"
    assert model.topic("/robot1/cmd_vel", "publish", "new") is None
    assert [t.direction for t in model.publications()] == ["publish"]
    assert [t.direction for t in model.subscriptions()] == ["subscribe"]
    assert model.timer("tick").period == 0.1 and model.timer("nope") is None
    assert model.service("/robot1/mb_wrapper/reset").handler == "reset"


def test_a_basenode_is_described_as_a_person_names_it():
    assert BaseModel("move_base", "ipyros_demo").describe() == "ipyros_demo/move_base"
    assert BaseModel("./counter_node.py").describe() == "./counter_node.py"
    assert BaseModel("/x/bag_player.py", bag={"path": "/data/run1.bag", "rate": 1.0}).describe() == "bag /data/run1.bag"
    launched = BaseModel("planner", "nav", launch="$(find nav)/nav.launch", launch_node="/planner")
    assert launched.describe() == "/planner of $(find nav)/nav.launch"
