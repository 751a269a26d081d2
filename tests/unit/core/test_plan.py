"""The plan: from a node model to the endpoints that must run (the wrapping semantics of the paper's fig. 1)."""

from __future__ import annotations

from ipyros.core import plan as planning
from ipyros.core.model import ActionModel, BaseModel, NodeModel, ServiceModel, TimerModel, TopicModel
from ipyros.core.plan import (
    ActionRelaySpec,
    ActionServerSpec,
    PublishSpec,
    RelaySpec,
    ServiceRelaySpec,
    ServiceSpec,
    SubscribeSpec,
    TimerSpec,
)
from ipyros.core.qos import Qos

TWIST = "geometry_msgs/Twist"


def wrapper(*topics: TopicModel, services: tuple = (), timers: tuple = ()) -> NodeModel:
    return NodeModel("w", "/", BaseModel(executable="b", package="p"), list(topics), list(timers), list(services))


def topic(name: str, direction: str, role: str = "new", handler: str | None = None, **more) -> TopicModel:
    return TopicModel(name, name, direction, TWIST, role, handler, **more)


def test_a_plain_node_publishes_and_subscribes_where_it_says():
    model = NodeModel("n", "/", None, [topic("/out", "publish"), topic("/in", "subscribe", handler="h")])
    assert list(planning.plan(model)) == [PublishSpec("/out", TWIST), SubscribeSpec("/in", TWIST, "topic /in")]


def test_reuse_publish_relays_the_basenodes_output_out():
    plan = list(planning.plan(wrapper(topic("/cmd_vel", "publish", "reuse"))))
    assert plan == [RelaySpec("/w/base/cmd_vel", "/cmd_vel", TWIST)]


def test_reuse_subscribe_relays_the_world_in():
    plan = list(planning.plan(wrapper(topic("/scan", "subscribe", "reuse"))))
    assert plan == [RelaySpec("/scan", "/w/base/scan", TWIST)]


def test_a_placed_basenodes_relays_run_on_its_machine_unless_a_guard_elsewhere_must_see_them():
    from ipyros.core.model import GuardModel

    model = wrapper(topic("/cmd_vel", "publish", "reuse"), topic("/scan", "subscribe", "reuse"))
    assert model.base is not None
    model.base.machine = "robot1"
    assert list(planning.plan(model)) == [RelaySpec("/w/base/cmd_vel", "/cmd_vel", TWIST, "robot1"),
                                          RelaySpec("/scan", "/w/base/scan", TWIST, "robot1")]
    model.services.append(ServiceModel("/reset", "/reset", "std_srvs/Empty", "reuse"))
    model.actions.append(ActionModel("/spin", "/spin", "test_msgs/Fibonacci", "reuse"))
    placed = planning.plan(model)
    assert planning.ServiceRelaySpec("/w/base/reset", "/reset", "std_srvs/Empty", "robot1") in placed
    assert planning.ActionRelaySpec("/w/base/spin", "/spin", "test_msgs/Fibonacci", "robot1") in placed
    model.guards.append(GuardModel("/cmd_vel", "/cmd_vel", TWIST, machine="robot1"))
    assert RelaySpec("/w/base/cmd_vel", "/cmd_vel", TWIST, "robot1") in planning.plan(model), "its guard is there too"
    for elsewhere in (None, "robot2"):  # a gate of the session's, or another machine's: the relay runs here
        model.guards[0].machine = elsewhere
        assert RelaySpec("/w/base/cmd_vel", "/cmd_vel", TWIST) in planning.plan(model)
        assert RelaySpec("/scan", "/w/base/scan", TWIST, "robot1") in planning.plan(model)


def test_intercepting_an_output_hands_the_basenodes_messages_to_the_handler_and_takes_the_public_name():
    plan = list(planning.plan(wrapper(topic("/cmd_vel", "publish", "reuse"),
                                      topic("/cmd_vel", "subscribe", "new", "h"))))
    assert SubscribeSpec("/w/base/cmd_vel", TWIST, "topic /cmd_vel") in plan
    assert PublishSpec("/cmd_vel", TWIST, follows="/w/base/cmd_vel") in plan, "latched if the basenode's is"
    assert not any(isinstance(s, RelaySpec) for s in plan)
    latched = list(planning.plan(wrapper(topic("/map", "publish", "reuse", latch=True),
                                         topic("/map", "subscribe", "new", "h"))))
    assert PublishSpec("/map", TWIST, latch=True) in latched, "declared latched: as declared, following nothing"


def test_intercepting_an_input_feeds_the_basenode_through_write():
    plan = list(planning.plan(wrapper(topic("/goal", "subscribe", "reuse"), topic("/goal", "subscribe", "new", "h"))))
    assert plan == [SubscribeSpec("/goal", TWIST, "topic /goal"), PublishSpec("/w/base/goal", TWIST)]


def test_write_targets():
    model = wrapper(topic("/goal", "subscribe", "reuse"), topic("/goal", "subscribe", "new", "h"),
                    topic("/cmd", "publish", "reuse"), topic("/cmd", "subscribe", "new", "g"),
                    topic("/extra", "publish"))
    assert planning.write_target(model, "/goal") == "/w/base/goal"
    assert planning.write_target(model, "/cmd") == "/cmd"
    assert planning.write_target(model, "/extra") == "/extra"
    assert planning.write_target(model, "/nothing") is None


def test_services_relayed_or_answered():
    relayed = wrapper(services=(ServiceModel("/reset", "/reset", "std_srvs/Empty", "reuse"),))
    assert list(planning.plan(relayed)) == [ServiceRelaySpec("/w/base/reset", "/reset", "std_srvs/Empty")]
    answered = wrapper(services=(ServiceModel("/reset", "/reset", "std_srvs/Empty", "reuse"),
                                 ServiceModel("/reset", "/reset", "std_srvs/Empty", "new", "h")))
    assert list(planning.plan(answered)) == [ServiceSpec("/reset", "std_srvs/Empty", "service /reset")]


def test_timers_and_their_slots():
    model = NodeModel("n", timers=[TimerModel("tick", 0.5, "f", oneshot=True)])
    assert list(planning.plan(model)) == [TimerSpec("tick", 0.5, True, "timer tick")]
    assert planning.timer_slot("tick") == "timer tick"
    assert planning.service_slot("/s") == "service /s"
    assert planning.topic_slot("/t") == "topic /t"


def test_the_plan_keeps_qos_and_latch():
    model = NodeModel("n", topics=[topic("/map", "publish", latch=True, qos={"depth": 1, "durability": "transient_local"})])
    (spec,) = planning.plan(model)
    assert spec == PublishSpec("/map", TWIST, True, Qos(1, None, "transient_local"))


def test_internal_names_live_under_the_wrapping_node():
    model = NodeModel("w", "/robot1/")
    assert planning.node_fullname(model) == "/robot1/w"
    assert planning.internal_name(model, "/robot1/cmd_vel") == "/robot1/w/base/robot1/cmd_vel"


def test_the_plan_is_a_pure_function_of_the_model():
    model = wrapper(topic("/a", "publish", "reuse"), topic("/b", "subscribe", "new", "h"))
    assert list(planning.plan(model)) == list(planning.plan(model))
    assert model == wrapper(topic("/a", "publish", "reuse"), topic("/b", "subscribe", "new", "h"))


# -- actions ---------------------------------------------------------------------------------
FIB = "test_msgs/Fibonacci"


def with_actions(*actions: ActionModel) -> NodeModel:
    model = wrapper()
    model.actions = list(actions)
    return model


def test_reuse_action_relays_the_basenodes_action_as_one_unit():
    plan = list(planning.plan(with_actions(ActionModel("/fib", "/fib", FIB, "reuse"))))
    assert plan == [ActionRelaySpec("/w/base/fib", "/fib", FIB)]


def test_new_action_serves_the_goals_and_forwards_to_the_basenode_only_when_it_wraps_that_action():
    served = list(planning.plan(with_actions(ActionModel("/fib", "/fib", FIB, "new", "h"))))
    assert served == [ActionServerSpec("/fib", FIB, "action /fib", None)]
    intercepted = list(planning.plan(with_actions(ActionModel("/fib", "/fib", FIB, "reuse"),
                                                  ActionModel("/fib", "/fib", FIB, "new", "h"))))
    assert intercepted == [ActionServerSpec("/fib", FIB, "action /fib", "/w/base/fib")], "no relay beside it"
