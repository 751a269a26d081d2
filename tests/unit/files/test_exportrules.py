"""A guard's rules in an exported node (files/exportrules.py): rendered from what the session compiled, they judge as
the session's :class:`~ipyros.core.rules.RuleSet` does, command by command and with none coming, on hostile inputs.

The exported judging is plain Python run here as the exported script runs it (its text executed, no ipyros in it);
the inputs stand in for a laser (``/scan``: a Sample whose ``gains`` are the ranges), a bumper and a battery.
"""

from __future__ import annotations

import copy
import math
import random

import pytest
from unit_msgs.msg import Gain, Sample, Twist, Vector3

from ipyros.core.errors import IpyrosError
from ipyros.core.model import GuardModel
from ipyros.core.rules import RuleSet, rule
from ipyros.files.export import GUARD_FUNCTIONS
from ipyros.files.exportrules import RULES_FUNCTIONS, rules_source

RULES = [rule("min(/scan.gains) < 0.3", stop=True),
         rule("min(/scan.gains[0:2]) < 1.0 and abs(linear.x) > 0.1", limit={"linear.x": (-0.3, 0.3)}, hold=0.2),
         rule("/bumper.on", only="linear.x <= 0 or angular.z == 0"),
         rule("/battery.level < 0.2 or len(/scan.gains) == 1", scale=0.5),
         rule("0.1 < /battery.level * 2 < 0.5 - -0.1", limit={"angular.z": (-0.5, 0.5)}),
         rule("max(/scan.fixed[-1], /battery.level) > 5 and not /bumper.on", limit={"linear.y": (0.0, 0.0)}),
         rule("/scan.gains[0] / /battery.level > 100", stop=True)]
STALE = {"/scan": 0.5, "/bumper": 0.5}
HOSTILE = (math.nan, math.inf, -math.inf, 1e308, -0.0, 0.0, 0.05, 0.3, -0.31, 0.31, 1.0, -2.0)
RAYS = (math.nan, math.inf, 0.0, 0.29, 0.3, 0.31, 0.99, 1.0, 2.0, 5.0, 7.5)
LEVELS = (math.nan, math.inf, 0.0, 0.1, 0.19, 0.2, 0.21, 0.9)


def exported(rules=RULES, stale=STALE):
    """The exported node's ``Rules(...)``, made as the script makes it: its text run with nothing of ipyros."""
    guard = GuardModel("cmd_vel", "/cmd_vel", "unit_msgs/Twist", rules=[r.as_data() for r in rules], stale=stale)
    source = rules_source(guard, Twist, lambda type_name: type_name.split("/")[1],
                          {"/scan": "unit_msgs/Sample", "/bumper": "unit_msgs/Sample", "/battery": "unit_msgs/Sample"})
    script: dict = {"Sample": Sample}
    exec("import copy, math, threading, time\n" + GUARD_FUNCTIONS + RULES_FUNCTIONS, script)  # noqa: S102 - the script
    return eval(source, script)  # noqa: S307 - what the exported script runs


def values(msg) -> tuple:
    return tuple(repr(v) for v in (msg.linear.x, msg.linear.y, msg.linear.z, msg.angular.x, msg.angular.y,
                                   msg.angular.z))


def test_the_exported_rules_judge_as_the_sessions_on_hostile_inputs_with_and_without_a_command():
    session = RuleSet(RULES, Twist, "/cmd_vel", STALE, "guard /cmd_vel")
    there = exported()
    rng = random.Random(49)
    heard: dict = {}
    now, last = 100.0, None
    makers = {"/scan": lambda: Sample(gains=[rng.choice(RAYS) for _ in range(rng.choice((0, 1, 2, 3, 3)))],
                                      fixed=[0.0, 0.0, rng.choice((0.0, 6.0))]),
              "/bumper": lambda: Sample(on=rng.random() < 0.3),
              "/battery": lambda: Sample(level=rng.choice(LEVELS))}
    seen = {"stopped": 0, "changed": 0, "passed": 0, "idle stop": 0}
    for step in range(5000):
        now += rng.random() * 0.1
        for topic, make in makers.items():
            roll = rng.random()
            if roll < 0.4:
                heard[topic] = (make(), now - rng.random() * 0.3)
            elif roll < 0.42:
                heard[topic] = (make(), now - 0.8)  # stale
            elif roll < 0.43:
                heard[topic] = (Gain(), now)  # of the wrong type
            elif roll < 0.44:
                heard.pop(topic, None)
        command = Twist(linear=Vector3(x=rng.choice(HOSTILE), y=rng.choice(HOSTILE)),
                        angular=Vector3(z=rng.choice(HOSTILE)))
        out, why, stopped = session.apply(session.judge(heard, now, command), command, Twist)
        told, judged = there.judge(heard, now, command)
        theirs, said = (None, told) if told else there.apply(judged, copy.deepcopy(command))
        assert (theirs is None) == stopped, f"step {step}: the session {'stopped' if stopped else 'passed'} ({why}), " \
                                            f"the exported node said {said!r}"
        if not stopped:
            assert values(theirs) == values(out), f"step {step}: {why}"
            last = out
        seen["stopped" if stopped else "changed" if why else "passed"] += 1
        idle = session.idle(heard, now, last, Twist)
        assert bool(there.idle(heard, now, last)) == bool(idle), f"step {step}, no command: the session said {idle!r}"
        seen["idle stop"] += bool(idle)
    assert min(seen.values()) > 100, seen  # every way was taken, many times


def test_an_input_whose_type_the_graph_does_not_show_is_refused_at_export_in_one_line():
    guard = GuardModel("cmd_vel", "/cmd_vel", "unit_msgs/Twist", rules=[RULES[0].as_data()])
    with pytest.raises(IpyrosError, match=r"read /scan, and nothing publishes it now.*start what publishes it"):
        rules_source(guard, Twist, str, {})


def test_an_exported_guard_sends_nothing_until_its_inputs_are_heard_then_the_stop_when_a_rule_says_so():
    script: dict = {"Sample": Sample}
    exec("import copy, math, threading, time\n" + GUARD_FUNCTIONS + RULES_FUNCTIONS, script)  # noqa: S102
    sent, hearing = [], {}
    guard = script["Guard"](sent.append, Twist(), rules=exported(RULES[:1], {}),
                            listen=lambda topic, cls, hear: hearing.setdefault(topic, hear))
    guard.publish(Twist(linear=Vector3(x=0.2)))
    assert sent == [] and list(hearing) == ["/scan"], "nothing judged, nothing sent before the laser is heard"
    hearing["/scan"](Sample(gains=[2.0]))
    guard.publish(Twist(linear=Vector3(x=0.2)))
    assert [m.linear.x for m in sent] == [0.2]
    hearing["/scan"](Sample(gains=[0.1]))  # an obstacle, no new command: the stop message at once
    assert [m.linear.x for m in sent] == [0.2, 0.0]


def test_an_exported_guard_whose_rules_fail_to_judge_sends_the_stop_message_and_its_watch_goes_on():
    script: dict = {"Sample": Sample}
    exec("import copy, math, threading, time\n" + GUARD_FUNCTIONS + RULES_FUNCTIONS, script)  # noqa: S102
    sent, hearing = [], {}
    rules = exported(RULES[:1], {})
    guard = script["Guard"](sent.append, Twist(), rules=rules, listen=lambda topic, cls, hear: hearing.setdefault(
        topic, hear))
    hearing["/scan"](Sample(gains=[2.0]))
    rules.judge = rules.idle = lambda *args: 1 / 0  # what its judging may never do, if it ever did
    guard.publish(Twist(linear=Vector3(x=0.2)))
    assert [m.linear.x for m in sent] == [0.0], "a command: the stop message in its place"
    hearing["/scan"](Sample(gains=[2.0]))  # no command: the stop message, said, and nothing raised
    assert [m.linear.x for m in sent] == [0.0, 0.0]
