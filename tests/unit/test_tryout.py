"""What %try shows, without ROS: a trial over a bag as a table (counts per output, first differences)."""

from __future__ import annotations

from ipyros.tools.tryout import BagTrial, Difference, Outcome, Write


def test_a_bag_trial_shows_counts_per_output_and_the_first_differences_side_by_side():
    live, candidate = Outcome("", (Write("n", "/out", 30),), None, 0.1), Outcome("", (Write("n", "/out", 31),), None, 0.1)
    trial = BagTrial("n", "/in", "run", "scale", "scale_v2", total=50, differing=1,
                     outputs={"live": {"/out": [(0.0, 3)] * 50}, "candidate": {"/out": [(0.0, 3)] * 49, "/log": [(1.0, "x")]}},
                     first=(Difference(0.9, 10, live, candidate),), others=1, seconds=0.25)
    lines = str(trial).splitlines()
    assert lines[0] == ("scale_v2 against scale on 50 messages of /in from run (and 1 of its other subscriptions, "
                        "through their live handlers): 1 differ (0.25 s)")
    rows = [line.split() for line in lines[3:]]
    assert rows[0] == ["/log", "0", "1"] and rows[1] == ["/out", "50", "49"]
    assert lines[-1].startswith("at 0.900 s: 10") and "write /out: 30" in lines[-1] and "write /out: 31" in lines[-1]
