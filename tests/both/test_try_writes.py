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


def test_try_swaps_nothing_process_wide_and_other_threads_print_as_usual(ip, capsys):
    """What a tried handler prints and writes is kept for the table, in the trying thread alone: rosNode.write and
    sys.stdout are the same objects during the try as after it (before the change, both were swapped for the try
    and back), and a print of another thread meanwhile reaches the output."""
    ok(ip, "import sys, threading\nfrom std_msgs.msg import String\nfrom ipyros import rosNode as _R\n"
           "seen_during = []\n"
           "def talker_print():\n    print('ANOTHER THREAD PRINTS')\n"
           "def live(msg):\n    print('live got', msg.data)\n    tp.write('/try_p/out', msg)\n"
           "def candidate(msg):\n"
           "    seen_during.append((_R.write, sys.stdout))\n"
           "    other = threading.Thread(target=talker_print); other.start(); other.join()\n"
           "    print('candidate got', msg.data)\n"
           "tp = rosNode('try_p').new.subscribe('/try_p/in', live, msgType=String)"
           ".publish('/try_p/out', msgType=String).create()\n"
           "feeder = rosNode('try_p_feeder').new.publish('/try_p/in', msgType=String).create()\n"
           "feeder.timer(0.05, lambda: feeder.write('/try_p/in', String(data='x')))")
    wait_for(lambda: ip.user_ns["tp"].status().row("/try_p/in").calls >= 2, timeout=20, what="messages for live")
    write = ip.user_ns["_R"].write
    capsys.readouterr()
    ok(ip, "%try -n 1 tp /try_p/in candidate")
    out = capsys.readouterr().out
    after = (ip.user_ns["_R"].write, __import__("sys").stdout)
    # the same objects during the try as after it: nothing was swapped in for the try and back out
    assert ip.user_ns["seen_during"] == [after] and after[0] is write, "something process-wide was swapped"
    assert "ANOTHER THREAD PRINTS" in out, out
    table = out.split("ANOTHER THREAD PRINTS")[-1]
    assert "candidate got x" in table and "live got x" in table and "write /try_p/out" in table, out
