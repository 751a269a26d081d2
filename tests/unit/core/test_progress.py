"""What a progress view says: done of total, the rate, the time left; nothing where nobody watches."""

from __future__ import annotations

from ipyros.core.progress import Tally, no_progress


def test_a_tally_says_done_of_total_the_rate_and_the_time_left():
    tally = Tally("%try /scan over run.bag", 100_000, "messages", started=100.0)
    tally.done = 45_000
    assert tally.line(now=101.5) == "%try /scan over run.bag: 45,000 of 100,000 messages, 30,000/s, 2 s left"
    tally.done = 1_000
    assert tally.line(now=101.0).endswith("1,000/s, 1 min 39 s left")


def test_without_a_total_it_says_what_is_done_or_how_long_it_has_waited():
    assert Tally("converting", None, "messages", done=2048, started=10.0).line(now=12.0) == \
        "converting: 2,048 messages, 1,024/s"
    assert Tally("waiting for /move_base", None, started=10.0).line(now=13.2) == "waiting for /move_base: 3 s"


def test_no_progress_draws_nothing_and_takes_every_step():
    with no_progress("work", 10, "items") as step:
        for done in range(10):
            step(done)


def test_work_measured_in_seconds_says_no_rate():
    assert Tally("recording /scan to run.bag", 20, "s", done=3, started=10.0).line(now=13.0) == \
        "recording /scan to run.bag: 3 of 20 s, 17 s left"
