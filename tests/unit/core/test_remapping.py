"""Wrapping rules as the DSL applies them, on the model alone: names resolved as the basenode resolves them,
remaps composed (one remap per name), declarations that must go together."""

from __future__ import annotations

import pytest

from ipyros.core import remapping as wrap
from ipyros.core.errors import DeclarationError
from ipyros.core.model import ActionModel, BaseModel, NodeModel, ServiceModel, TopicModel


def model(base: BaseModel | None = None, namespace: str = "/", **more) -> NodeModel:
    return NodeModel("w", namespace, base, **more)


def test_base_names_default_to_the_executable():
    assert wrap.base_node_name(BaseModel(executable="move_base")) == "move_base"
    assert wrap.base_node_name(BaseModel(executable="/opt/x/talker.py")) == "talker"
    assert wrap.base_node_name(BaseModel(executable="2d-nav")) == "n2d_nav"
    assert wrap.base_node_name(BaseModel(executable="x", node_name="/planner")) == "planner"


def test_reuse_names_resolve_in_the_basenodes_namespace_and_under_its_name():
    m = model(BaseModel(executable="move_base", package="p", namespace="robot1"))
    assert wrap.resolve_for(m, "reuse", "cmd_vel", "topic") == "/robot1/cmd_vel"
    assert wrap.resolve_for(m, "reuse", "~goal", "topic") == "/robot1/move_base/goal"
    assert wrap.resolve_for(m, "new", "cmd_vel", "topic") == "/cmd_vel"
    assert wrap.base_fullname(m) == "/robot1/move_base"


def test_a_new_declaration_spelled_like_a_reuse_one_means_the_basenodes_name():
    m = model(BaseModel(executable="move_base", package="p", namespace="robot1"),
              topics=[TopicModel("~goal", "/robot1/move_base/goal", "publish", "t/T", "reuse")])
    assert wrap.resolve_for(m, "new", "~goal", "topic") == "/robot1/move_base/goal"


def test_the_basenodes_own_remaps_apply_to_reuse_names():
    m = model(BaseModel(executable="b", package="p", remaps={"cmd_vel": "/mobile_base/cmd"}))
    assert wrap.resolve_for(m, "reuse", "cmd_vel", "topic") == "/mobile_base/cmd"


def test_remaps_compose_without_chains():
    m = model(BaseModel(executable="b", package="p", remaps={"cmd_vel": "/mobile_base/cmd", "odom": "/odom2"}),
              topics=[TopicModel("cmd_vel", "/mobile_base/cmd", "publish", "t/T", "reuse")])
    assert wrap.basenode_remaps(m) == {"/cmd_vel": "/w/base/mobile_base/cmd", "/odom": "/odom2",
                                       "/mobile_base/cmd": "/w/base/mobile_base/cmd"}


def test_services_are_remapped_too():
    m = model(BaseModel(executable="b", package="p"), services=[ServiceModel("reset", "/reset", "s/S", "reuse")])
    assert wrap.basenode_remaps(m) == {"/reset": "/w/base/reset"}


def test_reuse_without_a_basenode_is_refused():
    m = model(topics=[TopicModel("a", "/a", "publish", "t/T", "reuse")])
    with pytest.raises(DeclarationError, match="has no basenode"):
        wrap.check_wrapping(m)


@pytest.mark.parametrize("base, message", [
    (BaseModel(package="p"), "add .baseNode"),
    (BaseModel(executable="talker"), "add .basePackage"),
])
def test_an_incomplete_basenode_is_refused(base, message):
    with pytest.raises(DeclarationError, match=message):
        wrap.check_wrapping(model(base))


def test_a_path_needs_no_package():
    wrap.check_wrapping(model(BaseModel(executable="./talker.py")))


@pytest.mark.parametrize("base, whence", [
    (BaseModel(executable="./camera.py", own_name="w"), "the name its code gives it"),
    (BaseModel(executable="./camera.py", node_name="w"), "the name given it"),
    (BaseModel(executable="./w.py"), "the name of its executable"),
])
def test_a_basenode_of_the_wrapping_nodes_own_name_is_refused(base, whence):
    with pytest.raises(DeclarationError, match=rf"w and its basenode would both be /w \({whence}\).*rosNode\('w_wrap'\)"):
        wrap.check_wrapping(model(base))
    wrap.check_wrapping(model(BaseModel(executable="./camera.py", own_name="w", namespace="robot")))  # /robot/w, /w


def test_one_basenode_is_wrapped_once():
    first = model(BaseModel(executable="talker", package="p"))
    second = NodeModel("w2", "/", BaseModel(executable="talker", package="p"))
    with pytest.raises(DeclarationError, match="already wrapped by /w"):
        wrap.check_wrapping(second, [first])


def test_a_base_topic_is_wrapped_once():
    m = model(BaseModel(executable="b", package="p"), topics=[TopicModel("a", "/a", "publish", "t/T", "reuse")])
    with pytest.raises(DeclarationError, match="wrapped once"):
        wrap.check_reuse(m, "/a", "subscribe")
    wrap.check_reuse(m, "/a", "publish")  # the same declaration again is a redeclaration, not a clash


def test_a_wrapped_action_is_remapped_by_the_parts_its_ros_names():
    m = model(BaseModel(executable="nav", package="p", namespace="r1"),
              actions=[ActionModel("navigate", "/r1/navigate", "a/Nav", "reuse")])
    assert wrap.basenode_remaps(m) == {"/r1/navigate": "/w/base/r1/navigate"}  # ROS 2: the action's name
    ros1 = wrap.basenode_remaps(m, ("/goal", "/cancel", "/status", "/feedback", "/result"))
    assert ros1["/r1/navigate/goal"] == "/w/base/r1/navigate/goal" and len(ros1) == 5
    assert wrap.resolve_for(m, "new", "navigate", "action") == "/r1/navigate", "new spelled as the reuse intercepts"
