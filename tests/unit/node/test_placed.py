"""A guard placed on another machine (:mod:`ipyros.node.placed`), pure: a keeper that does not say it judges the
guard's rules (an older ipyros on the robot) is refused, never trusted to enforce what it drops."""

from __future__ import annotations

from typing import Any

import pytest
from unit_msgs.msg import Twist

from ipyros.core.rules import RuleSet, rule
from ipyros.node.placed import PlacedGuard
from ipyros.processes.keeper import MachineError


class Keeper:
    """What a guard's link to a keeper is asked, and what the keeper answers a placing."""

    def __init__(self, answer: dict[str, Any]) -> None:
        self.answer, self.asked = answer, []

    def ask(self, op: str, **fields: Any) -> dict[str, Any]:
        self.asked.append((op, fields.get("on", fields.get("hold"))))
        return self.answer if op == "place" else {}


def placed(answer: dict[str, Any]) -> tuple[PlacedGuard, Keeper]:
    guard = PlacedGuard.__new__(PlacedGuard)  # its link and rules only: no ROS, no keeper process
    guard.topic, guard.machine, guard.shared = "/cmd_vel", "robot1", type("Shared", (), {})()
    guard.rules = RuleSet([rule("min(/scan.gains) < 0.5", stop=True)], Twist, "/cmd_vel", {"/bumper": 0.3}, "guard")
    guard._link = keeper = Keeper(answer)
    guard._spec = lambda: {}  # type: ignore[method-assign]
    return guard, keeper


@pytest.mark.parametrize("again, undone", [(False, ("remove", True)), (True, ("estop", True))])
def test_a_keeper_that_does_not_read_the_rules_inputs_is_refused_and_the_guard_there_holds_the_stop(again, undone):
    guard, keeper = placed({"id": "1"})  # an older keeper: it answers the placing, and drops the rules
    with pytest.raises(MachineError, match=r"^guard /cmd_vel: the keeper of machine robot1 does not judge a guard's "
                                           r"rules \(an older ipyros runs there\).*; update ipyros there"):
        guard._place(again=again)
    assert keeper.asked == [("place", None), undone]


def test_a_keeper_that_reads_them_is_trusted():
    guard, keeper = placed({"id": "1", "reads": ["/bumper", "/scan"]})
    guard._place()
    assert keeper.asked == [("place", None)]
