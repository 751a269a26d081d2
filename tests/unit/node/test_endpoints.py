"""Opening what a plan lists, one opener per kind (:mod:`ipyros.node.endpoints`)."""

from __future__ import annotations

import typing

from ipyros.core import plan as planning
from ipyros.node.endpoints import OPENERS, describe


def test_every_kind_of_endpoint_the_plan_makes_has_an_opener():
    assert set(OPENERS) == set(typing.get_args(planning.Spec))


def test_an_endpoint_in_a_few_words():
    assert describe(planning.PublishSpec("/x", "std_msgs/String")) == "publisher /x"
    assert describe(planning.RelaySpec("/n/base/x", "/x", "std_msgs/String")) == "relay /n/base/x -> /x"
    assert describe(planning.TimerSpec("tick", 1.0, False, "timer tick")) == "timer tick"
    assert describe(planning.ActionRelaySpec("/n/base/a", "/a", "t/A")) == "action relay /n/base/a -> /a"
