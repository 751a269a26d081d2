"""Guard rules over what the robot senses (core/rules.py): declared as data, compiled once, judged fail-closed.

The inputs stand in for a laser (``/scan``: a Sample whose ``gains`` are the ranges), a bumper (``/bumper``: a
Sample whose ``on`` is pressed) and a battery (``/battery``: ``level``); the guarded command is a Twist.
"""

from __future__ import annotations

import math

import pytest
from unit_msgs.msg import Sample, Twist, Vector3

from ipyros.core.errors import DeclarationError
from ipyros.core.rules import RuleSet, compile_condition, rule

NEAR = rule("min(/scan.gains) < 0.5", limit={"linear.x": (-0.2, 0.2)})
BUMPER = rule("/bumper.on", only="linear.x <= 0")
BATTERY = rule("/battery.level < 0.1", stop=True)
TYPES = {"/scan": Sample, "/bumper": Sample, "/battery": Sample}


def twist(x: float, z: float = 0.0) -> Twist:
    return Twist(linear=Vector3(x=x), angular=Vector3(z=z))


def heard(at: float = 0.0, ranges=(2.0, 3.0), pressed: bool = False, level: float = 0.9):
    return {"/scan": (Sample(gains=list(ranges)), at), "/bumper": (Sample(on=pressed), at),
            "/battery": (Sample(level=level), at)}


def rules(*given, stale=None) -> RuleSet:
    return RuleSet(given or (NEAR, BUMPER, BATTERY), Twist, "/cmd_vel", {"/scan": 0.3} if stale is None else stale,
                   "guard /cmd_vel", TYPES)


def sent(ruleset: RuleSet, inputs, command, now: float = 0.1):
    out, why, stopped = ruleset.apply(ruleset.judge(inputs, now, command), command, lambda: twist(0.0))
    assert stopped == (out.linear.x == 0.0 and bool(why) and "->" not in why and "scaled" not in why)
    return out.linear.x, out.angular.z, why


def test_the_most_restrictive_rule_in_force_wins_and_nothing_changes_when_none_holds():
    ruleset = rules()
    assert sent(ruleset, heard(), twist(0.5)) == (0.5, 0.0, "")
    assert sent(ruleset, heard(ranges=(0.4, 3.0)), twist(0.5))[:2] == (0.2, 0.0), "limited near an obstacle"
    assert sent(ruleset, heard(pressed=True), twist(0.5))[:2] == (0.0, 0.0), "only backing off: a stop"
    assert sent(ruleset, heard(pressed=True), twist(-0.3))[:2] == (-0.3, 0.0), "backing off passes"
    assert sent(ruleset, heard(ranges=(0.4,), level=0.05), twist(-0.1)) == (0.0, 0.0, "rule 3: /battery.level < 0.1")
    slower = rules(rule("min(/scan.gains) < 1", scale=0.5), rule("min(/scan.gains) < 0.8", scale=0.25),
                   rule("min(/scan.gains) < 0.5", limit={"linear.x": (-0.1, 0.1)}))
    assert sent(slower, heard(ranges=(0.9,)), twist(0.4, 0.8))[:2] == (0.2, 0.4), "the curve kept"
    assert sent(slower, heard(ranges=(0.7,)), twist(0.4, 0.8))[:2] == (0.1, 0.2), "the smallest ratio"
    assert sent(slower, heard(ranges=(0.4,)), twist(0.8, 0.8))[:2] == (0.1, 0.2), "scaled, then clamped"
    both = rules(rule("true", limit={"linear.x": (-1, 0.3)}), rule("true", limit={"linear.x": (0.1, 2)}), stale={})
    assert sent(both, {}, twist(0.0))[0] == 0.1 and sent(both, {}, twist(0.9))[0] == 0.3, "the limits' intersection"


def test_an_input_never_heard_stale_or_that_cannot_be_judged_is_a_stop():
    ruleset = rules()
    never = heard()
    del never["/bumper"]
    assert sent(ruleset, never, twist(0.5)) == (0.0, 0.0, "/bumper not heard yet")
    assert "/scan stale (0.40 s old, at most 0.3 s)" == sent(ruleset, heard(at=0.0), twist(0.5), now=0.4)[2]
    assert sent(ruleset, heard(level=math.nan), twist(0.5))[:2] == (0.0, 0.0), "a NaN compared"
    assert "rule 1 could not be told" in sent(ruleset, heard(ranges=(math.nan,)), twist(0.5))[2], "no ray left"
    assert sent(ruleset, heard(ranges=(math.nan, 0.4)), twist(0.5))[0] == 0.2, "a NaN ray is left out of min"
    for ranges in ((0.4, math.nan, 2.0), (2.0, math.nan, 0.4), (math.nan, math.nan, 0.4, math.nan)):
        assert sent(ruleset, heard(ranges=ranges), twist(0.5))[0] == 0.2, f"NaN rays left out wherever: {ranges}"
    assert sent(ruleset, heard(ranges=(math.inf, 2.0)), twist(0.5))[0] == 0.5, "an infinite ray is far"
    assert "rule 1 could not be told" in sent(ruleset, heard(ranges=(True, 2.0)), twist(0.5))[2], "a bool is no range"
    wrong = heard()
    wrong["/battery"] = (Twist(), 0.0)  # of another type than the rule reads: its field is not there
    assert "rule 3 could not be told" in sent(ruleset, wrong, twist(0.5))[2]
    stale_only = RuleSet((), Twist, "/cmd_vel", {"/odom": 0.5}, "guard /cmd_vel")
    assert stale_only.topics == ("/odom",) and sent(stale_only, {}, twist(0.5))[2] == "/odom not heard yet"


def test_a_rule_holds_for_its_hold_after_its_condition_ends():
    ruleset = rules(rule("min(/scan.gains) < 0.5", stop=True, hold=1.0))
    assert sent(ruleset, heard(at=0.0, ranges=(0.4,)), twist(0.5), now=0.0)[2] == "rule 1: min(/scan.gains) < 0.5"
    clear = heard(at=0.5)
    assert sent(ruleset, clear, twist(0.5), now=0.5)[0] == 0.0, "held"
    assert sent(ruleset, heard(at=1.1), twist(0.5), now=1.1) == (0.5, 0.0, "")


def test_judged_without_a_command_an_obstacle_that_appears_stops_the_last_command():
    ruleset = rules()
    stop = lambda: twist(0.0)  # noqa: E731
    assert ruleset.idle(heard(), 0.1, twist(0.5), stop) == ""
    assert "linear.x 0.5 -> 0.2" in ruleset.idle(heard(ranges=(0.4,)), 0.1, twist(0.5), stop), "would be limited"
    assert ruleset.idle(heard(ranges=(0.4,)), 0.1, twist(0.1), stop) == "", "within the new limit: nothing to do"
    assert ruleset.idle(heard(at=0.0), 0.5, None, stop).startswith("/scan stale"), "stale, before any command"
    about_command = rules(rule("linear.x > 0 and min(/scan.gains) < 0.5", stop=True))
    assert about_command.idle(heard(ranges=(0.4,)), 0.1, None, stop) == "", "no command: nothing to stop"
    assert about_command.idle(heard(ranges=(0.4,)), 0.1, twist(0.3), stop).startswith("rule 1")


@pytest.mark.parametrize("condition, said", [
    ("min(/scan.gains) <", "does not parse at its end"),
    ("min(/scan.gains) < < 1", "does not parse at column 20"),
    ("min(/scan.gains)", "is not a true/false condition"),
    ("/scan.gains[0] + 1", "is not a true/false condition"),
    ("__import__('os').system('x') == 0", "a call of"),
    ("linear.__class__ == 1", "is not a field"),
    ("/scan.nope < 1", "Sample has no field 'nope'"),
    ("/cmd_vel.linear.x > 1", "reads the guarded output itself"),
    ("linear.q > 1", "'linear.q': no field 'q' in the command (it has x, y, z)"),
    ("speed > 1", "no field 'speed' in the command (it has linear, angular)"),
    ("'text' == 1", "'text' is not a number"),
    ("[1, 2] == 1", "is not allowed"),
])
def test_a_rule_given_wrong_is_one_line_at_declaration(condition, said):
    with pytest.raises(DeclarationError) as error:
        rules(rule(condition, stop=True))
    assert said in str(error.value) and "\n" not in str(error.value)


@pytest.mark.parametrize("kwargs, said", [
    ({}, "give one action"),
    ({"stop": True, "scale": 0.5}, "not scale and stop (make two rules)"),
    ({"limit": {"linear.x": (1, -1)}}, "low <= high"),
    ({"scale": 1.5}, "from 0 to 1"),
    ({"stop": True, "hold": -1}, "hold=-1"),
    ({"only": ""}, "only=''"),
])
def test_a_rules_shape_given_wrong_is_one_line(kwargs, said):
    with pytest.raises(DeclarationError) as error:
        rule("true", **kwargs)
    assert said in str(error.value)


def test_the_stop_message_must_meet_the_rules_it_stands_for():
    ruleset = rules(rule("true", limit={"linear.x": (0.1, 0.3)}), BUMPER)
    with pytest.raises(DeclarationError, match=r"linear.x = 0, outside rule 1's limit 0.1..0.3"):
        ruleset.check_stop(twist(0.0), "guard /cmd_vel")
    with pytest.raises(DeclarationError, match=r"breaks rule 1's only='linear.x <= 0'"):
        rules(BUMPER).check_stop(twist(0.2), "guard /cmd_vel")
    rules(BUMPER).check_stop(twist(0.0), "guard /cmd_vel")


def test_a_condition_reads_paths_fields_and_division_apart_and_a_rule_reads_back_as_data():
    condition = compile_condition("abs(linear.x)/2 > min(/scan.gains[0:2]) and not /bumper.on", "here")
    assert [p.text for p in condition.inputs] == ["/scan.gains[0:2]", "/bumper.on"]
    assert condition.fields == ("linear.x",)
    assert condition.holds([[0.1, 5.0], False], twist(0.4)) and not condition.holds([[0.3, 5.0], False], twist(0.4))
    again = rule(**NEAR.as_data())
    assert again == NEAR and str(NEAR) == "when min(/scan.gains) < 0.5: limit linear.x -0.2..0.2"


def test_a_rule_that_cannot_be_applied_to_the_command_is_the_stop_message():
    """A limit on a fixed array the sender gave as a tuple cannot be clamped in place: the stop message, never the
    command unchecked."""
    ruleset = RuleSet([rule("true", limit={"fixed[0]": (0.0, 1.0)})], Sample, "/out", {}, "guard /out")
    command = Sample(fixed=(5.0, 0.0, 0.0))
    out, why, stopped = ruleset.apply(ruleset.judge({}, 0.0, command), command, lambda: Sample())
    assert stopped and out == Sample() and "could not be applied" in why
