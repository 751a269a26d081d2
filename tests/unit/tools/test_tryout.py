"""What %try shows, without ROS: a trial over a bag as a table (counts per output, first differences)."""

from __future__ import annotations

import pytest
from unit_msgs.msg import Twist, Vector3

from ipyros.core.errors import IpyrosError
from ipyros.tools.plot import series_chart
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


def trial_of(outputs):
    return BagTrial("n", "/in", "run", "scale", "scale_v2", total=3, differing=3, outputs=outputs, first=())


def test_a_trial_gives_one_field_of_each_sides_outputs_over_bag_time():
    twists = {"live": {"/cmd": [(t, Twist(linear=Vector3(x=t))) for t in (0.0, 0.5, 1.0)]},
              "candidate": {"/cmd": [(t, Twist(linear=Vector3(x=2 * t))) for t in (0.0, 0.5)]}}
    assert trial_of(twists).series("linear.x") == ("/cmd.linear.x", [("scale (live)", [0.0, 0.5, 1.0], [0.0, 0.5, 1.0]),
                                                                     ("scale_v2 (candidate)", [0.0, 0.5], [0.0, 1.0])])
    assert trial_of(twists).series("/cmd.linear.x")[0] == "/cmd.linear.x"
    chart = series_chart("/cmd.linear.x", trial_of(twists).series("linear.x")[1], "bag time (s)", width=20, height=5)
    assert chart.splitlines()[0] == "/cmd.linear.x: * scale (live)  o scale_v2 (candidate)" and "bag time (s)" in chart


def test_a_field_to_plot_given_wrong_is_one_line():
    several = {"live": {"/cmd": [(0.0, Twist())], "/log": [(0.0, Twist())]}, "candidate": {}}
    with pytest.raises(IpyrosError, match=r"^--plot linear.x: the handlers wrote on /cmd, /log: name the topic too, "
                                          r"e.g. --plot /cmd.linear.x$"):
        trial_of(several).series("linear.x")
    with pytest.raises(IpyrosError, match="a Vector3, not a number: plot a number field"):
        trial_of({"live": {"/cmd": [(0.0, Twist())]}, "candidate": {}}).series("linear")
    with pytest.raises(IpyrosError, match="neither scale nor scale_v2 wrote anything"):
        trial_of({"live": {}, "candidate": {}}).series("linear.x")
    with pytest.raises(IpyrosError, match="a Twist, not a number"):
        trial_of({"live": {"/cmd": [(0.0, Twist())]}, "candidate": {}}).series("/cmd")


def test_a_side_that_did_nothing_is_said_once_not_a_column_of_dashes():
    """A handler that writes nothing (a logger, a candidate that only prints elsewhere): said once in the title, its
    cells empty; in the live %try view its column is left out and the heading says why."""
    import io

    from rich.console import Console

    from ipyros.ipython.display import trial_view
    from ipyros.tools.tryout import TrialReport, TrialRow

    nothing, wrote = Outcome("", (), None, 0.1), Outcome("", (Write("n", "/out", 31),), None, 0.1)
    trial = BagTrial("n", "/in", "run", "scale", "quiet", total=2, differing=2,
                     outputs={"live": {"/out": [(0.0, 31)] * 2}, "candidate": {}},
                     first=(Difference(0.1, 1, wrote, nothing), Difference(0.2, 2, wrote, nothing)))
    text = str(trial)
    assert text.splitlines()[0].endswith("; quiet did nothing on the first differences shown"), text
    assert not any(line.rstrip().endswith(" -") for line in text.splitlines()), text
    report = TrialReport("n", "/in", "scale", "quiet", tuple(TrialRow(i, i, wrote, nothing) for i in (1, 2)))
    buffer = io.StringIO()
    Console(file=buffer, width=120, color_system=None).print(trial_view(report))
    shown = " ".join(buffer.getvalue().split())
    assert "(candidate quiet printed, wrote and raised nothing)" in shown and "(nothing)" not in shown, shown
    assert "candidate: quiet" not in shown and "live: scale" in shown, shown
