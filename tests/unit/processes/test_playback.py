"""A bag's playing and its controls (:mod:`ipyros.processes.playback`), pure: on a clock the test moves."""

from __future__ import annotations

import math

import pytest

from ipyros.processes.playback import Playback, parse_state

S = 1_000_000_000  # ns a second


class Clock:
    def __init__(self) -> None:
        self.now = 50.0

    def __call__(self) -> float:
        return self.now


def playback(rate=1.0, loop=False):
    clock = Clock()
    return Playback(100 * S, 110 * S, rate, loop, clock), clock


def test_bag_time_runs_at_the_rate_and_messages_come_due_at_their_stamps():
    p, clock = playback(rate=2.0)
    assert p.now() == 100 * S and p.wait(101 * S) == pytest.approx(0.5)
    clock.now += 0.5
    assert p.now() == 101 * S and p.wait(101 * S) == 0.0
    p.sent(101 * S)
    assert p.sent_count == 1


def test_paused_time_stands_still_and_nothing_is_due_until_resumed():
    p, clock = playback()
    clock.now += 1.0
    assert p.command("pause") is None and p.paused
    clock.now += 5.0
    assert p.now() == 101 * S and p.wait(101 * S) == math.inf
    assert p.command("resume") is None
    clock.now += 1.0
    assert p.now() == 102 * S


def test_step_sends_the_next_messages_at_once_then_holds():
    p, clock = playback()
    assert p.command("step 2") is None and p.paused
    assert p.wait(105 * S) == 0.0
    p.sent(105 * S)
    p.sent(107 * S)
    clock.now += 3.0
    assert p.now() == 107 * S and p.wait(108 * S) == math.inf  # held after its two messages


def test_seek_says_where_to_read_from_and_rate_and_loop_change_as_told():
    p, clock = playback()
    assert p.command("seek 4.5") is None and p.seek_to == 104 * S + S // 2 and p.now() == p.seek_to
    assert p.command("rate 0.5") is None
    clock.now += 2.0
    assert p.now() == 105 * S + S // 2
    assert p.command("loop on") is None and p.loop


@pytest.mark.parametrize("text, problem", [
    ("seek 11", "seek 11: the bag lasts 10.000 s; give seconds from its start, 0 to that"),
    ("seek -1", "seek -1: the bag lasts 10.000 s"),
    ("rate 0", "rate 0: give a speed factor above 0 and at most 1000 (1 as recorded)"),
    ("rate fast", "rate fast: rate takes a number"),
    ("step 0", "step 0: give how many messages to send, 1 or more"),
    ("loop maybe", "loop maybe: give on or off"),
    ("rewind", "'rewind': the controls are pause, resume, step N, seek SECONDS, rate R, loop on|off"),
])
def test_a_control_given_wrong_changes_nothing_and_says_why_in_one_line(text, problem):
    p, _ = playback()
    assert p.command(text).startswith(problem) and not p.paused and p.rate == 1.0 and p.seek_to is None


def test_the_state_line_reads_back():
    p, clock = playback(rate=2.0, loop=True)
    p.command("pause")
    ident, fields, problem = parse_state(p.state("7"))
    assert ident == "7" and problem is None
    assert fields == {"at": "0.000", "paused": "1", "rate": "2", "loop": "1", "sent": "0", "length": "10.000"}
    assert parse_state(p.state("8", "rate 0: give a speed"))[2] == "rate 0: give a speed"


def test_play_publishes_in_order_from_where_a_seek_says_and_answers_each_control(capsys):
    import queue

    from ipyros.processes.playback import play

    stamps = [100 * S + i * 1_000_000 for i in range(10)]  # a message a millisecond

    def read(start):
        return iter([("/t", s, i) for i, s in enumerate(stamps) if start is None or s >= start])

    controls: queue.Queue = queue.Queue()
    controls.put("1 seek 0.005")
    controls.put("2 rate 4")
    published = []
    play(Playback(stamps[0], stamps[-1]), read, lambda topic, msg: published.append(msg), controls, lambda: True)
    assert published == [5, 6, 7, 8, 9]
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("bag_player: state 1 at=0.005 paused=0 rate=1 ")
    assert lines[1].startswith("bag_player: state 2 ") and "rate=4" in lines[1]
    assert lines[-1] == "bag_player: played to the end"


def test_a_player_reads_back_the_arguments_the_session_gives_it():
    """One parser for both ROS's players, reading what player_args writes (topics last: every word after it)."""
    from ipyros.processes.playback import parse_player_args, player_args

    args = parse_player_args(player_args("/bags/run.bag", 2.0, True, ["/scan", "/odom"], 0.5, clock=True))
    assert (args.bag, args.rate, args.loop, args.delay, args.clock, args.topics) == \
        ("/bags/run.bag", 2.0, True, 0.5, True, ["/scan", "/odom"])
    plain = parse_player_args(player_args("run", 1.0, False, None, 1.0))
    assert (plain.loop, plain.clock, plain.topics) == (False, False, None)
