"""A guard's rules and the gate every message of a guarded output passes (:mod:`ipyros.core.guard`), pure: on
messages of both ROS's shapes, with a clock the test moves."""

from __future__ import annotations

import json
import math
import random

import pytest
from unit2_msgs.msg import Pose
from unit_msgs.msg import Sample, Twist, Vector3

from ipyros.core import guard
from ipyros.core.errors import DeclarationError


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def gate(cls=Twist, limits=None, rates=None, on_limit="clamp", estopped=lambda: False, clock=None):
    said: list[str] = []
    passed: list[int] = []
    made = guard.Gate("/cmd_vel", cls, limits or {}, rates or {}, on_limit, cls, estopped,
                      lambda: passed.append(1), said.append, clock or Clock())
    return made, said, passed


LIMITS = {"linear.x": (-0.5, 0.5), "angular.z": (-1.0, 1.0)}


def test_a_message_within_its_limits_passes_as_it_came():
    g, said, passed = gate(limits=LIMITS)
    msg = Twist(linear=Vector3(x=0.3), angular=Vector3(z=-0.2))
    verdict = g.check(msg)
    assert verdict.send is msg and verdict.why == "" and (msg.linear.x, msg.angular.z) == (0.3, -0.2)
    assert said == [] and passed == [1]


def test_a_value_outside_is_clamped_and_said_once_per_episode():
    clock = Clock()
    g, said, _ = gate(limits=LIMITS, clock=clock)
    for x in (3.0, 2.0, -7.0):
        verdict = g.check(Twist(linear=Vector3(x=x), angular=Vector3(z=5.0)))
        assert verdict.why == "clamped" and verdict.send.linear.x == max(min(x, 0.5), -0.5)
        assert verdict.send.angular.z == 1.0
    assert len(said) == 1 and said[0].startswith("guard /cmd_vel: clamped (linear.x 3 -> 0.5, angular.z 5 -> 1)")
    g.check(Twist())  # passes as it came
    clock.now += guard.EPISODE_QUIET  # and a quiet second: the episode ends
    g.check(Twist(linear=Vector3(x=9.0)))
    assert len(said) == 2 and g.figures.clamped == 4 and g.figures.passed == 5


def test_kinds_of_acting_that_alternate_are_each_said_once_an_episode():
    """A basenode gone wrong alternates clamped, clean and NaN values: two lines, not one a message."""
    clock = Clock()
    g, said, _ = gate(limits=LIMITS, clock=clock)
    for n in range(300):
        clock.now += 0.02
        g.check(Twist(linear=Vector3(x=(3.0, 0.1, math.nan)[n % 3])))
    assert [s.split(": ", 1)[1][:12] for s in said] == ["clamped (lin", "linear.x is "], said
    assert g.figures.clamped == g.figures.replaced == 100


def test_what_is_said_is_reported_as_a_value_once_an_episode_and_kind_and_as_a_line_of_json():
    clock = Clock()
    reported: list[tuple[guard.Acting, str]] = []
    g = guard.Gate("/cmd_vel", Twist, LIMITS, {}, "clamp", Twist, lambda: False, lambda: None, lambda text: None,
                   clock, report=lambda acting, why: reported.append((acting, why)))
    for n in range(30):
        clock.now += 0.02
        g.check(Twist(linear=Vector3(x=(3.0, 0.1, math.nan)[n % 3])))
    assert reported == [(guard.Acting.CLAMPED, "clamped (linear.x 3 -> 0.5)"),
                        (guard.Acting.NOT_FINITE, "linear.x not finite")]  # the reason alone, not the sentence
    assert json.loads(guard.verdict_text("/cmd_vel", guard.Acting.NOT_FINITE, "linear.x not finite", 12.5)) == \
        {"output": "/cmd_vel", "acting": "not finite", "why": "linear.x not finite", "stamp": 12.5}


def test_on_limit_drop_sends_nothing():
    g, said, passed = gate(limits=LIMITS, on_limit="drop")
    assert g.check(Twist(linear=Vector3(x=0.6))).send is None
    assert passed == [] and g.figures.dropped == 1 and "linear.x = 0.6 is outside its limits: dropped" in said[0]


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_nan_and_infinities_anywhere_never_pass_the_stop_message_goes_instead(value):
    g, said, passed = gate(limits={"linear.x": (-0.5, 0.5)})
    verdict = g.check(Twist(angular=Vector3(y=value)))  # a field without a limit: still never passes
    assert verdict.send == Twist() and verdict.why == "non-finite angular.y" and passed == [1]
    assert said == ["guard /cmd_vel: angular.y is not a finite number: the stop message was sent in its place"]


def test_e_stopped_every_message_becomes_the_stop_message():
    held = [True]
    g, said, _ = gate(limits=LIMITS, estopped=lambda: held[0])
    for _ in range(3):
        assert g.check(Twist(linear=Vector3(x=0.1))).send == Twist()
    # said once by who e-stopped it (the magic, or the session's watch for an e-stop topic), not by the gate
    assert said == [] and g.figures.last_trip.startswith("e-stopped") and g.figures.replaced == 3
    held[0] = False
    assert g.check(Twist(linear=Vector3(x=0.1))).send.linear.x == 0.1


def test_a_rate_limit_ramps_a_field_from_the_last_value_that_passed():
    clock = Clock()
    g, said, _ = gate(rates={"linear.x": 1.0}, clock=clock)
    assert g.check(Twist()).send.linear.x == 0.0
    clock.now += 0.1
    assert g.check(Twist(linear=Vector3(x=2.0))).send.linear.x == pytest.approx(0.1)
    clock.now += 0.5
    assert g.check(Twist(linear=Vector3(x=2.0))).send.linear.x == pytest.approx(0.6)
    clock.now += 0.1
    assert g.check(Twist(linear=Vector3(x=-2.0))).send.linear.x == pytest.approx(0.5)
    g.stopped()  # the output went to rest: it ramps up from the stop message again
    clock.now += 0.1
    assert g.check(Twist(linear=Vector3(x=2.0))).send.linear.x == pytest.approx(0.1)


def test_array_elements_and_nested_fields_by_path():
    g, _, _ = gate(cls=Sample, limits={"gains[*]": (0, 1), "fixed[1]": (-1, 1), "points[*].x": (0, 2),
                                       "count": (0, 10)})
    msg = Sample(gains=[0.5, 3.0, -1.0], fixed=(5.0, 5.0, 5.0), points=[Vector3(x=9), Vector3(x=1)], count=99)
    sent = g.check(msg).send
    assert sent.gains == [0.5, 1.0, 0.0] and tuple(sent.fixed) == (5.0, 1.0, 5.0)
    assert [p.x for p in sent.points] == [2.0, 1.0] and sent.count == 10 and type(sent.count) is int


def test_ros2_shaped_messages_are_guarded_the_same():
    g, _, _ = gate(cls=Pose, limits={"position.x": (-1, 1), "weights[:]": (0, 1)})
    sent = g.check(Pose(weights=[2.0, 0.5], position=None)).send
    assert sent.weights == [1.0, 0.5]
    sent = g.check(Pose(weights=[math.nan])).send
    assert sent == Pose()


def test_no_hostile_value_gets_through_in_100000_messages():
    """NaN, infinities, huge values, negative zero, the wrong sign: what leaves the gate is within its limits."""
    g, _, _ = gate(limits=LIMITS)
    hostile = [math.nan, math.inf, -math.inf, 1e308, -1e308, -0.0, 0.0, -0.5000001, 0.5000001, 3.0, -3.0, 0.4]
    rng = random.Random(7)
    for _ in range(100_000):
        sent = g.check(Twist(linear=Vector3(x=rng.choice(hostile), y=rng.choice(hostile)),
                             angular=Vector3(z=rng.choice(hostile)))).send
        assert sent is not None
        assert -0.5 <= sent.linear.x <= 0.5 and -1.0 <= sent.angular.z <= 1.0 and math.isfinite(sent.linear.y)


@pytest.mark.parametrize("path, says", [
    ("linear.q", "'linear.q': no field 'q' (there: x, y, z)"),
    ("speed", "'speed': no field 'speed' (there: linear, angular)"),
    ("linear", "'linear' is a unit_msgs/Vector3, not a number"),
    ("linear.x.y", "linear.x.y"),
    ("linear[0].x", "'linear[0].x': linear is not an array"),
    ("", "a field is named by its path"),
])
def test_a_path_that_names_no_number_is_one_line_naming_the_fields(path, says):
    with pytest.raises(DeclarationError) as caught:
        guard.parse_path(Twist, path, "guard('/cmd_vel')")
    assert says in str(caught.value) and "\n" not in str(caught.value), str(caught.value)


def test_an_array_path_must_name_its_elements():
    with pytest.raises(DeclarationError, match=r"an array of float64: limit its elements, 'gains\[\*\]'"):
        guard.parse_path(Sample, "gains", "g")
    with pytest.raises(DeclarationError, match=r"points is an array; name its elements"):
        guard.parse_path(Sample, "points.x", "g")
    assert guard.parse_path(Sample, "points[-1].x", "g").steps == (("points", -1), ("x", None))


@pytest.mark.parametrize("settings, says", [
    (dict(limits={"linear.x": (1, -1)}), "give (low, high), two finite numbers with low <= high"),
    (dict(limits={"linear.x": (0, math.nan)}), "give (low, high)"),
    (dict(limits=[("linear.x", 1)]), "give a dict of field paths and (low, high)"),
    (dict(rate={"linear.x": 0}), "give the most the field may change in a second, a number above 0"),
    (dict(on_limit="wrap"), "give 'clamp'"),
    (dict(timeout=0), "give the seconds of silence after which the stop message is sent, from 0.01 up"),
    (dict(timeout=True), "timeout=True"),
    (dict(grace=30), "from 0 to 10"),
    (dict(repeat=0), "from 0.5 to 1000"),
])
def test_settings_given_wrong_are_one_line_saying_what_to_give(settings, says):
    given = {**dict(limits=None, rate=None, on_limit="clamp", timeout=0.5, grace=3.0, repeat=10.0), **settings}
    with pytest.raises(DeclarationError) as caught:
        guard.check_rules(Twist, given["limits"], given["rate"], given["on_limit"], given["timeout"],
                          given["grace"], given["repeat"], "nd.guard('/cmd_vel')")
    assert says in str(caught.value) and str(caught.value).startswith("nd.guard('/cmd_vel'): "), str(caught.value)


def test_the_finite_checker_names_the_first_bad_path():
    check = guard.finite_checker(Sample)
    assert check(Sample()) is None
    assert check(Sample(gains=[1.0, math.inf])) == "gains[1]"
    assert check(Sample(points=[Vector3(), Vector3(z=math.nan)])) == "points[1].z"
    assert check(Sample(level=math.nan)) == "level"


def test_the_senders_message_is_left_as_it_was():
    g, _, _ = gate(limits=LIMITS, rates={"angular.z": 0.1})
    mine = Twist(linear=Vector3(x=3.0))
    sent = g.check(mine).send
    assert mine.linear.x == 3.0 and sent.linear.x == 0.5 and sent is not mine


def test_a_stop_message_the_gate_would_not_pass_is_refused_in_one_line():
    """The e-stop and the stop on silence send the stop message unchecked: one outside the guard's own limits (3 m/s
    under a limit of 0.5) or holding a NaN is refused when declared; the zero message outside them too."""
    with pytest.raises(DeclarationError) as caught:
        guard.check_stop(Twist, Twist(linear=Vector3(x=3.0)), LIMITS, "nd.guard('/cmd_vel')", given=True)
    assert str(caught.value) == ("nd.guard('/cmd_vel'): the stop message has linear.x = 3, outside the guard's own "
                                 "limits -0.5..0.5: the e-stop would send it; give stop= within the limits")
    with pytest.raises(DeclarationError, match=r"the stop message \(the type's zero message\) has linear.x = 0, "
                                               r"outside the guard's own limits 0.1..0.5"):
        guard.check_stop(Twist, Twist(), {"linear.x": (0.1, 0.5)}, "g", given=False)
    with pytest.raises(DeclarationError, match="the stop message's angular.z is not a finite number"):
        guard.check_stop(Twist, Twist(angular=Vector3(z=math.nan)), {}, "g", given=True)
    guard.check_stop(Twist, Twist(linear=Vector3(x=-0.5)), LIMITS, "g", given=True)  # on the limit: within


def test_while_messages_are_replaced_the_gate_says_why_and_stops_saying_it_once_one_passes_or_a_while_after():
    clock = Clock()
    g, _, _ = gate(limits=LIMITS, clock=clock)
    assert g.replacing == ""
    g.check(Twist(linear=Vector3(x=math.nan)))
    assert g.replacing == "linear.x not finite"
    g.check(Twist(linear=Vector3(x=9.0)))  # clamped: a command passes
    assert g.replacing == ""
    g.check(Twist(angular=Vector3(z=math.inf)))
    assert g.replacing == "", "a command passed within the second: commands and replacements mixed pass"
    clock.now += guard.EPISODE_QUIET
    g.check(Twist(angular=Vector3(z=math.inf)))
    assert g.replacing == "angular.z not finite"
    clock.now += guard.EPISODE_QUIET  # nothing sent since: no longer "stopping"
    assert g.replacing == ""


def test_a_verdict_says_what_the_gate_did_as_a_value():
    """Verdicts are values (an enum and the field that made them so), for whoever reads them, not a sentence to
    parse; ``why`` is the same in words."""
    g, _, _ = gate(limits=LIMITS)
    cases = [(Twist(linear=Vector3(x=0.1)), guard.Acting.PASSED, ""),
             (Twist(linear=Vector3(x=3.0)), guard.Acting.CLAMPED, ""),
             (Twist(angular=Vector3(y=math.nan)), guard.Acting.NOT_FINITE, "angular.y")]
    for msg, acting, path in cases:
        verdict = g.check(msg)
        assert (verdict.acting, verdict.path) == (acting, path)
    dropping, _, _ = gate(limits=LIMITS, on_limit="drop")
    verdict = dropping.check(Twist(angular=Vector3(z=-2.0)))
    assert (verdict.send, verdict.acting, verdict.path, verdict.why) == (None, guard.Acting.DROPPED, "angular.z",
                                                                         "outside its limits")
    held, _, _ = gate(limits=LIMITS, estopped=lambda: True)
    assert held.check(Twist()).acting is guard.Acting.ESTOPPED


def test_a_gate_with_rules_judges_each_command_by_what_was_heard_and_again_with_none_coming():
    """The rules act between the NaN check and the guard's own limits: a stale input is the stop message in the
    command's place (said once), a limit in force clamps (said with the rules' words), and idle() judges the last
    command that passed against what is heard now."""
    from ipyros.core.rules import RuleSet, rule

    clock, said = Clock(), []
    heard = {"/scan": (Sample(gains=[2.0]), clock.now)}
    rules = RuleSet([rule("min(/scan.gains) < 0.5", limit={"linear.x": (-0.2, 0.2)})], Twist, "/cmd_vel",
                    {"/scan": 0.5}, "guard /cmd_vel")
    made = guard.Gate("/cmd_vel", Twist, {"linear.x": (-1.0, 1.0)}, {}, "clamp", Twist, lambda: False, lambda: None,
                      said.append, clock, rules=rules, heard=lambda: heard)
    assert made.check(Twist(linear=Vector3(x=0.4))).send.linear.x == 0.4
    assert made.idle() == ""
    heard["/scan"] = (Sample(gains=[0.3]), clock.now)
    assert "linear.x 0.4 -> 0.2" in made.idle(), "the last command would now be limited"
    verdict = made.check(Twist(linear=Vector3(x=0.4)))
    assert (verdict.send.linear.x, verdict.acting) == (0.2, guard.Acting.CLAMPED) and "rules:" in said[-1]
    clock.now += 1.0  # the scan was not heard again: stale
    verdict = made.check(Twist(linear=Vector3(x=0.1)))
    assert verdict.acting is guard.Acting.RULE_STOPPED and verdict.send == Twist()
    assert verdict.why.startswith("/scan stale") and made.idle().startswith("/scan stale")
    assert made.figures.replaced == 1 and made.replacing.startswith("/scan stale")


def test_the_rule_watch_sends_the_stop_at_the_guards_rate_and_says_each_change_once():
    """What a guard's rules do with no command coming (the session's guard and a keeper's share it): the stop
    message at the guard's rate while they hold it; their start said once with why, their end said once, except
    after a last command they would have changed (the stop message that replaced it passes them: no news)."""
    watch = guard.RuleWatch(repeat=4.0)
    assert watch.look("", 10.0) == (False, None)
    assert watch.look("/scan stale (0.6 s)", 10.0) == (True, (guard.Acting.RULE_STOPPED, "/scan stale (0.6 s)"))
    assert watch.ruling == "/scan stale (0.6 s)"
    assert watch.look("/scan stale (0.7 s)", 10.1) == (False, None), "within 1/repeat, and said already"
    assert watch.look("/scan stale (0.8 s)", 10.25) == (True, None)
    assert watch.look("", 10.3) == (False, (guard.Acting.PASSED, guard.RULES_PASS))
    assert guard.RuleWatch.line((guard.Acting.RULE_STOPPED, "rule 1: x")) == \
        "rule 1: x: the stop message goes out until its rules let a command pass"
    changed = "the last command would now be changed (linear.x 0.4 -> 0.2)"
    assert watch.look(changed, 11.0) == (True, (guard.Acting.RULE_STOPPED, changed))
    assert watch.look("", 11.1) == (False, None) and watch.ruling == ""


def test_no_hostile_command_breaks_four_rules_whose_inputs_change_underneath():
    """The bench's hostile run under rules (bench/guard.py runs 100,000 on each ROS's messages): commands of NaN,
    infinities and values just past each bound, through a stop, a limit, an only and a scale rule, while the laser,
    the bumper and the battery change between commands (no ray, NaN rays, stale, never heard, the wrong type). An
    oracle written from the rules' promises finds none outside them; every way out was taken."""
    from unit_msgs.msg import Gain

    from bench.guard import hostile_rules

    tally = hostile_rules(10_000, Twist, Vector3, (Sample, "gains"), (Sample, "on"), (Gain, "gain"), Vector3)
    assert tally["outside"] == 0, tally
    assert min(tally["stopped"], tally["changed"], tally["passed"]) > 500, tally
