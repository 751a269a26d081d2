"""%try on a handler that writes: both the live handler and the candidate are shown writing, as YAML (issue 25:
ROS 2 reported "would fail: carries geometry_msgs/Twist, not Twist" for both, and Python reprs)."""

from __future__ import annotations

from shell import ok
from support import wait_for


def test_try_shows_what_each_handler_writes(ip, capsys):
    ok(ip, "from geometry_msgs.msg import Twist\n"
           "def fast(msg):\n    msg.linear.x = 2.0\n    tw.write('/try_w/out', msg)\n"
           "tw = rosNode('try_w').new.subscribe('/try_w/in', fast, msgType=Twist)"
           ".publish('/try_w/out', msgType=Twist).create()\n"
           "feeder = rosNode('try_w_feeder').new.publish('/try_w/in', msgType=Twist).create()\n"
           "feeder.timer(0.05, lambda: feeder.write('/try_w/in', Twist()))")
    wait_for(lambda: ip.user_ns["tw"].status().row("/try_w/in").calls >= 3, timeout=20, what="messages for fast")
    capsys.readouterr()
    ok(ip, "%try -n 2 tw /try_w/in lambda m: tw.write('/try_w/out', m)")
    out = capsys.readouterr().out
    assert "would fail" not in out, out
    assert "write /try_w/out: {linear: {x: 2.0" in out and "write /try_w/out: {linear: {x: 0.0" in out, out
