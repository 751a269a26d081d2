"""``%try NODE TOPIC CANDIDATE --bag FILE``: the live handler and a candidate over every message of a recorded bag,
offline (the node is never created, nothing is published), the node's other subscriptions fed from the bag too."""

from __future__ import annotations

from shell import error_of, ok

BUILD = (
    "from std_msgs.msg import UInt32\n"
    "gain = [1]\n"
    "def set_gain(msg):\n    gain[0] = msg.data\n"
    "def scale(msg):\n    tb.write('/tb/out', UInt32(data=msg.data * gain[0]))\n"
    "def scale_v2(msg):\n    tb.write('/tb/out', UInt32(data=msg.data * gain[0] + (msg.data % 10 == 0)))\n"
    "tb = rosNode('tb')\n"
    "tb.new.subscribe('/tb/in', scale, msgType=UInt32).subscribe('/tb/gain', set_gain, msgType=UInt32)"
    ".publish('/tb/out', msgType=UInt32)\n"
)


def record(ip, path) -> None:
    """A bag written as %record writes one: the gain first, then 50 inputs."""
    ok(ip, "from ipyros.tools.record import bag_module\n"
           f"writer = bag_module().BagWriter(__import__('pathlib').Path({str(path)!r}))\n"
           "writer.write('/tb/gain', UInt32(data=3))\n"
           "for i in range(1, 51):\n    writer.write('/tb/in', UInt32(data=i))\n"
           "writer.close()")


def test_try_over_a_bag_runs_every_message_through_both_handlers_offline(ip, session, capsys, tmp_path):
    ok(ip, BUILD)
    bag = tmp_path / ("run.bag" if session.backend.name == "ROS 1" else "run")  # ROS 2: a rosbag2 folder
    record(ip, bag)
    capsys.readouterr()
    ok(ip, f"r = %try tb /tb/in scale_v2 --bag {bag}")
    r = ip.user_ns["r"]
    assert (r.total, r.differing, r.others) == (50, 5, 1)  # 10, 20, ..., 50 differ; the gain went through set_gain
    assert [m.data for _, m in r.outputs["live"]["/tb/out"]] == [3 * i for i in range(1, 51)]
    assert [m.data for _, m in r.outputs["candidate"]["/tb/out"]][9] == 31
    assert [d.message.data for d in r.first] == [10, 20, 30, 40, 50]
    assert all(t >= 0 for t, _ in r.outputs["live"]["/tb/out"])
    text = str(r)
    assert "scale_v2 against scale on 50 messages of /tb/in" in text and ": 5 differ" in text
    assert not ip.user_ns["tb"].created  # offline: the node never ran
    ok(ip, f"r2 = %try tb /tb/in scale --bag {bag}")
    assert ip.user_ns["r2"].differing == 0
    assert "no bag at" in str(error_of(ip, f"%try tb /tb/in scale --bag {tmp_path / 'nothing'}"))
    assert "tb has no handler for /tb/out" in str(error_of(ip, f"%try tb /tb/out scale --bag {bag}"))


def test_try_over_a_bag_plots_a_field_of_both_sides_over_bag_time(ip, session, capsys, tmp_path):
    ok(ip, BUILD)
    bag = tmp_path / ("plot.bag" if session.backend.name == "ROS 1" else "plot")
    record(ip, bag)
    capsys.readouterr()
    ok(ip, f"r = %try tb /tb/in scale_v2 --bag {bag} --plot data")
    chart = capsys.readouterr().out
    assert f"/tb/out.data over bag time, from {bag}: * scale (live)  o scale_v2 (candidate)" in chart, chart
    assert "151" in chart and "bag time (s)" in chart  # the top of the range: 3 x 50, and scale_v2 adds 1
    assert "--plot draws a try over a bag" in str(error_of(ip, "%try tb /tb/in scale_v2 --plot data"))
    assert "not a number" in str(error_of(ip, f"%try tb /tb/in scale_v2 --bag {bag} --plot /tb/out"))


def test_ctrl_c_stops_a_rehearsal_in_one_line_and_gives_what_ran_a_systemexit_is_the_candidates_error(
        ip, session, capsys, tmp_path):
    """Ctrl-C (a real SIGINT) at the 20th message: no traceback, the trial of the first 19 messages, said to be
    stopped. A candidate raising SystemExit is its error, counted like any other (it escaped %try before)."""
    ok(ip, BUILD)
    bag = tmp_path / ("stop.bag" if session.backend.name == "ROS 1" else "stop")
    record(ip, bag)
    ok(ip, "import os, signal\n"
           "def impatient(msg):\n"
           "    if msg.data == 20:\n        os.kill(os.getpid(), signal.SIGINT)\n"
           "    scale(msg)\n"
           "def leaves(msg):\n    raise SystemExit(3)")
    capsys.readouterr()
    ok(ip, f"r = %try tb /tb/in impatient --bag {bag}")
    r = ip.user_ns["r"]
    assert r.stopped and 19 <= r.total < 50 and r.differing == 0, (r.total, r.differing)
    out = capsys.readouterr()
    assert "KeyboardInterrupt" not in out.out + out.err
    assert "stopped by Ctrl-C, the rest of the bag not tried" in str(r)
    ok(ip, f"r = %try tb /tb/in leaves --bag {bag}")
    r = ip.user_ns["r"]
    assert (r.total, r.differing, r.stopped) == (50, 50, False)
    assert r.first[0].candidate.error == "SystemExit: 3"


GUARDED = (
    "from std_msgs.msg import Bool, Float32\n"
    "from geometry_msgs.msg import Twist, Vector3\n"
    "def drive(msg):\n    tg.write('/tg/cmd', Twist(linear=Vector3(x=msg.data)))\n"
    "def rush(msg):\n    tg.write('/tg/cmd', Twist(linear=Vector3(x=-5.0)))\n"
    "tg = rosNode('tg')\n"
    "tg.new.subscribe('/tg/in', drive, msgType=Float32)\n"
    "tg.new.publish('/tg/cmd', msgType=Twist)\n"
    "tg.guard('/tg/cmd', limits={'linear.x': (-1.0, 1.0)}, rules=[rule('/tg/bumper.data', only='linear.x <= 0')])\n"
)


def test_try_over_a_bag_shows_what_the_guards_let_reach_the_robot(ip, session, tmp_path):
    """Each write on a guarded output passes the node's guard as the session's would, its rules fed with the bag's
    own sensor messages: what reaches the robot, and how many writes each verdict took, per side."""
    ok(ip, GUARDED)
    bag = tmp_path / ("guarded.bag" if session.backend.name == "ROS 1" else "guarded")
    ok(ip, "from ipyros.tools.record import bag_module\n"
           f"writer = bag_module().BagWriter(__import__('pathlib').Path({str(bag)!r}))\n"
           "writer.write('/tg/bumper', Bool(data=False))\n"
           "for i in range(10):\n    writer.write('/tg/in', Float32(data=0.5))\n"
           "writer.write('/tg/bumper', Bool(data=True))\n"
           "for i in range(10):\n    writer.write('/tg/in', Float32(data=0.5))\n"
           "writer.close()")
    ok(ip, f"r = %try tg /tg/in rush --bag {bag}")
    r = ip.user_ns["r"]
    assert r.guarded == {"live": {"/tg/cmd": {"passed": 10, "stopped by a rule": 10}},
                         "candidate": {"/tg/cmd": {"clamped": 20}}}, r.guarded
    live, candidate = r.first[0].live.writes[0], r.first[0].candidate.writes[0]
    assert (live.guard, live.reached.linear.x) == ("", 0.5)
    assert candidate.guard == "clamped by its guard" and candidate.reached.linear.x == -1.0
    assert candidate.message.linear.x == -5.0, "what the handler wrote, kept as it wrote it"
    text = str(r)
    assert "its guard, /tg/cmd" in text and "10 passed, 10 stopped by a rule" in text and "20 clamped" in text
