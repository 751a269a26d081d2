"""What an agent may do beyond reading: each name in one spelling, allowed name by name, never past a guard."""

from __future__ import annotations

import pytest

from ipyros.core.errors import TopicNameError
from ipyros.mcp.allow import AgentRefused, Allowed, Reach, normal


@pytest.mark.parametrize("spelling", ["cmd_vel", "/cmd_vel", "/cmd_vel/", "//cmd_vel", "/./cmd_vel", " /cmd_vel ",
                                      "cmd_vel//", "/./cmd_vel/."])
def test_every_spelling_of_a_name_is_the_one_global_name(spelling):
    assert normal(spelling) == "/cmd_vel"


def test_relative_names_are_in_the_namespace_given():
    assert normal("cmd_vel", namespace="/robot1/") == "/robot1/cmd_vel"
    assert normal("/cmd_vel", namespace="/robot1/") == "/cmd_vel"


@pytest.mark.parametrize("bad, said", [("~cmd_vel", "private name"), ("/", "names nothing"), ("", "names nothing"),
                                       (5, "not int"), (None, "not NoneType")])
def test_names_that_are_no_topic_are_refused_in_one_line(bad, said):
    with pytest.raises(AgentRefused, match=said):
        normal(bad)


@pytest.mark.parametrize("bad", ["/a/../cmd_vel", "/a b", "1cmd", "/cmd-vel"])
def test_what_is_not_a_legal_ros_name_is_refused_not_guessed(bad):
    with pytest.raises(TopicNameError):
        normal(bad)


def test_publish_is_allowed_name_by_name_in_any_spelling():
    allowed = Allowed.of(publish=["cmd_vel"])
    assert allowed.to_publish("//cmd_vel/") == "/cmd_vel"
    with pytest.raises(AgentRefused,
                       match=r"may not publish on /cmd_vel2: allowed /cmd_vel; .*--allow-publish /cmd_vel2"):
        allowed.to_publish("cmd_vel2")
    with pytest.raises(AgentRefused, match="allowed none"):
        Allowed().to_publish("/cmd_vel")


def test_a_call_relayed_to_a_basenode_whose_outputs_are_guarded_is_refused_even_when_allowed():
    allowed = Allowed.of(call=["/base/reset", "/other/reset"])
    reach = Reach(relays={"/base/reset": "/base/driver"}, wrapped={"/base/driver": ("/cmd_vel",)})
    with pytest.raises(AgentRefused, match="relayed to the basenode /base/driver, whose outputs /cmd_vel are guarded"):
        allowed.to_call("base/reset/", reach)
    assert allowed.to_call("/other/reset", reach) == "/other/reset"
    with pytest.raises(AgentRefused, match="may not call /third"):
        allowed.to_call("/third", reach)


def test_swaps_are_allowed_node_by_node_and_said_in_one_line():
    allowed = Allowed.of(publish=["/cmd_vel"], swap=["/ctl"], ask=False)
    assert allowed.to_swap("/ctl") == "/ctl"
    with pytest.raises(AgentRefused, match="may not change /other's handlers"):
        allowed.to_swap("/other")
    assert allowed.describe() == "publish on /cmd_vel; propose handlers of /ctl (without asking)"
    assert Allowed().describe() == "read only"


def test_the_agents_relative_names_resolve_where_the_persons_did():
    allowed = Allowed.of(publish=["cmd_vel"], namespace="/robot1/")
    assert allowed.publish == {"/robot1/cmd_vel"}
    assert allowed.to_publish("cmd_vel") == allowed.to_publish("/robot1//cmd_vel/") == "/robot1/cmd_vel"
    with pytest.raises(AgentRefused, match="may not publish on /cmd_vel"):
        allowed.to_publish("/cmd_vel")
