"""``reuse`` declared (or removed) on a wrapped node that runs takes effect: the basenode is started again with
the remaps, and that is said (issue 24). A process's remaps are fixed at its start."""

from __future__ import annotations

from pathlib import Path

from shell import ok

STATUS_ONCE = Path(__file__).parent / "peers" / "status_once.py"


def test_a_reuse_declared_after_create_remaps_the_basenode(ip, peer, notices):
    ok(ip, "from std_msgs.msg import String\n"
           f"late = rosNode('late_wrap')\nlate.baseNode({str(STATUS_ONCE)!r}, namespace='late_robot')\n"
           "late.create()\n"
           "first_pid = late.base.pid")
    ok(ip, "late.reuse.publish('status', type=String)\n"
           "late.new.subscribe('status', lambda m: late.write('status', String(data=m.data + ' (wrapped)')),"
           " msgType=String)")
    assert any("restarting basenode /late_robot/status_once of late" in n for n in notices), notices
    assert ip.user_ns["late"].base.pid != ip.user_ns["first_pid"], "a new process, remapped"
    try:
        listener = peer("listen.py", "/late_robot/status", "std_msgs/String", "data", "--latched", "--name=late_ear")
        listener.wait_line("heard 'ready (wrapped)'", timeout=30)
        assert "heard 'ready'" not in listener.lines, "the basenode no longer publishes the public name itself"
        notices.clear()
        ok(ip, "late.new.subscribe('/late_robot/other', print, msgType=String)")
        assert not any("restarting" in n for n in notices), "a declaration that remaps nothing restarts nothing"
    finally:
        ok(ip, "late.shutdown()")
