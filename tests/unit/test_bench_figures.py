"""The bench's one table: a path that delivers nothing is a figure too ("0 delivered"), never a traceback."""

from __future__ import annotations

from bench.figures import Figure, compare, table, target_lines
from bench.relay_ros2 import Load, Run, targets

BEST_EFFORT = Load("image_be", "image", "Image 1 MiB, best effort, 30 Hz", 30.0, 60, 0, paths="ae",
                   reliability="best_effort")


def run(p50, lost):
    return Run(p50, None if p50 is None else p50 * 2, 0, 30, lost, 0.0, 0, 0, None, True)


def test_the_direct_path_delivering_nothing_is_the_anchor_of_the_wrapped_cameras_loss():
    figures = targets({("image_be", "a"): run(None, 60), ("image_be", "e"): run(2.0, 0)}, [BEST_EFFORT])
    lines = target_lines(figures)
    assert lines == ["- PASS ROS 2 Image 1 MiB, best effort, 30 Hz lost, wrapped camera (e), start included: 0 msgs "
                     "vs direct (a) 60 msgs (0.00x), target 0"], lines


def test_a_wrapped_camera_delivering_nothing_fails_its_loss_target_and_shows_no_latency():
    figures = targets({("image_be", "a"): run(None, 60), ("image_be", "e"): run(None, 60)}, [BEST_EFFORT])
    assert [f.what for f in figures] == ["Image 1 MiB, best effort, 30 Hz lost, wrapped camera (e), start included"]
    assert figures[0].passed is False


def test_a_figure_whose_anchor_has_no_value_is_printed():
    figure = Figure("ROS 2", "lost", 3, "msgs", "direct (a)", None, most=0)
    assert target_lines([figure]) == ["- FAIL ROS 2 lost: 3 msgs vs direct (a) -, target 0"]
    assert "| ROS 2 | lost | 3 msgs | direct (a) |  |" in table([figure])


def test_two_runs_side_by_side_show_each_runs_ratio_to_its_own_anchor():
    before = [Figure("ROS 2", "p50, relay (c)", 0.4, "ms", "direct (a)", 0.2, most=3.0),
              Figure("ROS 2", "only before", 1.0, "ms")]
    now = [Figure("ROS 2", "p50, relay (c)", 0.75, "ms", "direct (a)", 0.3, most=3.0),
           Figure("ROS 2", "only now", 1.0, "ms")]
    rows = compare(before, now).splitlines()
    assert rows[2:] == ["| ROS 2 | p50, relay (c) | direct (a) | 0.400 ms | 2.00x | 0.750 ms | 2.50x | <= 3x | PASS |"], rows


def test_a_figure_beside_two_anchors_is_compared_beside_each():
    before = [Figure("ROS 1", "p50 (c)", 0.1, "ms", "topic_tools (b)", 0.2), Figure("ROS 1", "p50 (c)", 0.1, "ms",
                                                                                  "direct (a)", 0.05)]
    now = [Figure("ROS 1", "p50 (c)", 0.08, "ms", "topic_tools (b)", 0.1), Figure("ROS 1", "p50 (c)", 0.08, "ms",
                                                                                 "direct (a)", 0.04)]
    rows = compare(before, now).splitlines()[2:]
    assert [row.split(" | ")[2:7] for row in rows] == [["topic_tools (b)", "0.100 ms", "0.50x", "0.080 ms", "0.80x"],
                                                       ["direct (a)", "0.100 ms", "2.00x", "0.080 ms", "2.00x"]]
