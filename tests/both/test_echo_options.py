"""%echo's rostopic options: --once, --noarr, --offset (issue 25)."""

from __future__ import annotations

import re

from shell import ok


def test_echo_once_without_arrays_and_with_times_from_now(ip, capsys):
    ok(ip, "from sensor_msgs.msg import JointState\n"
           "arm = rosNode('echo_opts').new.publish('/echo_opts/joints', msgType=JointState).create()\n"
           "def joints():\n"
           "    msg = JointState(name=['a', 'b'], position=[0.5, 1.5])\n"
           "    msg.header.stamp = stamp_now()\n"
           "    arm.write('/echo_opts/joints', msg)\n")
    ok(ip, "import time\n"
           "try:\n    import rospy\n    stamp_now = rospy.Time.now\n"
           "except ImportError:\n"
           "    from builtin_interfaces.msg import Time\n"
           "    def stamp_now():\n        t = time.time()\n        return Time(sec=int(t), nanosec=int(t % 1 * 1e9))\n"
           "arm.timer(0.05, joints)")
    capsys.readouterr()
    ok(ip, "seen = %echo /echo_opts/joints --once --noarr --offset")
    out = capsys.readouterr().out
    assert len(ip.user_ns["seen"]) == 1 and out.count("---") == 1, out
    assert "name: <array of 2 str>" in out and "position: <array of 2 float>" in out, out
    stamp = float(re.search(r"stamp: (\S+)", out).group(1))
    assert -5.0 < stamp <= 0.01, "the stamp as seconds from now: a moment ago"


def test_echo_table_rounds_floats_and_keeps_every_digit_in_the_messages(ip, capsys):
    ok(ip, "from std_msgs.msg import Float64\n"
           "third = rosNode('echo_third').new.publish('/echo_third/x', msgType=Float64).create()\n"
           "third.timer(0.05, lambda: third.write('/echo_third/x', Float64(data=1 / 3)))")
    capsys.readouterr()
    ok(ip, "rows = %echo /echo_third/x -n 1 --table")
    out = capsys.readouterr().out
    assert "0.333333" in out and "0.3333333333" not in out and "1 messages" not in out, out
    assert ip.user_ns["rows"][0].data == 1 / 3
