"""A message's numbers read from its serialized bytes (:mod:`ipyros.core.wire`), against bytes laid out by hand in
both encodings, and the gate's check of them (what a guarded relay forwards unchanged)."""

from __future__ import annotations

import math
import struct

import pytest
from unit_msgs.msg import Sample, Twist

from ipyros.core import guard, wire


class Stamped:
    """A message of each kind a layout reads or skips: a string first, so that CDR's padding depends on it."""

    __slots__ = ["frame", "on", "speed", "gains", "pair", "names", "raw"]
    _slot_types = ["string", "bool", "float64", "float64[]", "float32[2]", "string[]", "uint8[]"]


def cdr_stamped(speed: float = 1.5, gain: float = 0.25) -> bytes:
    """A Stamped in CDR, each padding written out: frame "abc", on, speed, gains [gain, 2.0], pair [3.0, 4.0],
    names ["x", "yz"], raw [1, 2, 3]. Offsets count from the end of the encapsulation header."""
    return (b"\x00\x01\x00\x00"                                           # little-endian plain CDR
            + struct.pack("<I", 4) + b"abc\x00"                         # 0: frame, its NUL counted
            + b"\x01" + b"\x00" * 7                                     # 8: on, then pad to 16
            + struct.pack("<d", speed)                                  # 16: speed
            + struct.pack("<I", 2) + b"\x00" * 4 + struct.pack("<2d", gain, 2.0)  # 24: count, pad to 32, gains
            + struct.pack("<2f", 3.0, 4.0)                              # 48: pair
            + struct.pack("<I", 2) + struct.pack("<I", 2) + b"x\x00"    # 56: names: 2, "x"
            + b"\x00\x00" + struct.pack("<I", 3) + b"yz\x00"            # 66: pad to 68, "yz"
            + b"\x00" + struct.pack("<I", 3) + b"\x01\x02\x03")         # 75: pad to 76, raw


def test_ros1_bytes_are_packed_and_every_scalar_is_named_in_order():
    layout = wire.layout(Twist, wire.ROS1)
    assert layout.names == ("linear.x", "linear.y", "linear.z", "angular.x", "angular.y", "angular.z")
    assert layout.read(struct.pack("<6d", 0.5, 0, 0, 0, 0, -1.25)) == [0.5, 0, 0, 0, 0, -1.25]


def test_cdr_pads_each_number_to_its_size_counted_after_the_encapsulation_header():
    layout = wire.layout(Stamped, wire.CDR)
    assert layout.names == ("on", "speed", "pair[0]", "pair[1]")
    assert layout.read(cdr_stamped()) == [True, 1.5, 3.0, 4.0]


def test_ros1_strings_and_sequences_are_skipped_by_their_lengths():
    raw = (struct.pack("<I", 2) + b"ab" + b"\x01" + struct.pack("<d", 1.5) + struct.pack("<I2d", 2, 0.25, 2.0)
           + struct.pack("<2f", 3.0, 4.0) + struct.pack("<II", 2, 1) + b"x" + struct.pack("<I", 2) + b"yz"
           + struct.pack("<I", 3) + b"\x01\x02\x03")
    assert wire.layout(Stamped, wire.ROS1).read(raw) == [True, 1.5, 3.0, 4.0]


@pytest.mark.parametrize("raw", [cdr_stamped(speed=math.nan), cdr_stamped(speed=-math.inf), cdr_stamped(gain=math.nan),
                                 cdr_stamped()[:-1], b"\x00\x00" + cdr_stamped()[2:]],
                         ids=["a NaN", "an infinity", "a NaN in a sequence", "cut short", "big-endian"])
def test_what_is_not_finite_or_not_as_laid_out_is_read_whole(raw):
    assert wire.layout(Stamped, wire.CDR).read(raw) is None


def test_a_type_with_an_array_of_messages_has_no_layout():
    assert wire.layout(Sample, wire.CDR) is None and wire.layout(Sample, wire.ROS1) is None


def make_gate(limits=None, rates=None, estopped=lambda: False, rules=None):
    passed: list[int] = []
    made = guard.Gate("/cmd_vel", Twist, limits or {}, rates or {}, "clamp", Twist, estopped,
                      lambda: passed.append(1), lambda text: None, rules=rules)
    return made, passed


def test_the_gate_passes_the_bytes_of_a_message_within_its_limits_and_counts_it():
    gate, passed = make_gate({"linear.x": (-0.5, 0.5)})
    passes = gate.raw_checker(wire.ROS1)
    assert passes(struct.pack("<6d", 0.5, 0, 0, 0, 0, 9.0))
    assert (gate.figures.passed, gate.commands, passed) == (1, 1, [1])
    assert not passes(struct.pack("<6d", 0.6, 0, 0, 0, 0, 0)), "outside: read whole, clamped by check()"
    assert not passes(struct.pack("<6d", 0, math.nan, 0, 0, 0, 0)), "not finite: the stop message, by check()"
    assert gate.figures.passed == 1


def test_an_e_stopped_gate_passes_no_bytes():
    gate, _ = make_gate(estopped=lambda: True)
    assert not gate.raw_checker(wire.ROS1)(struct.pack("<6d", 0, 0, 0, 0, 0, 0))


def test_rates_rules_or_a_limit_on_a_sequences_elements_read_every_message_whole():
    from ipyros.core.rules import RuleSet, rule

    assert make_gate(rates={"linear.x": 1.0})[0].raw_checker(wire.ROS1) is None
    rules = RuleSet([rule("/scan.level < 0.5", stop=True)], Twist, "/cmd_vel", {}, "guard")
    assert make_gate(rules=rules)[0].raw_checker(wire.ROS1) is None
    sample = guard.Gate("/s", Sample, {"gains[0]": (0.0, 1.0)}, {}, "clamp", Sample, lambda: False, lambda: None,
                        lambda text: None)
    assert sample.raw_checker(wire.CDR) is None


def test_ros1_floats_checked_by_their_sum_are_read_whole_when_it_overflows_and_never_pass_a_nan():
    layout = wire.layout(Twist, wire.ROS1)
    assert layout.read(struct.pack("<6d", 1e308, 1e308, 0, 0, 0, 0)) is None, "finite, but summed to inf: read whole"
    assert layout.read(struct.pack("<6d", math.inf, -math.inf, 0, 0, 0, 0)) is None
    stamped = wire.layout(Stamped, wire.ROS1)  # a run with one float among other numbers: its sum is itself
    raw = (struct.pack("<I", 0) + b"\x01" + struct.pack("<d", math.nan) + struct.pack("<I", 0)
           + struct.pack("<2f", 3.0, 4.0) + struct.pack("<II", 0, 0))
    assert stamped.read(raw) is None


def test_a_byte_check_that_raises_reads_the_message_whole_instead_of_dropping_it():
    gate, _ = make_gate({"linear.x": (-0.5, 0.5)})
    gate._raw_checkers[wire.ROS1] = lambda raw: 1 / 0  # what the byte check may never do, if it ever did
    assert gate.passes_raw(struct.pack("<6d", 0.1, 0, 0, 0, 0, 0), wire.ROS1) is False
