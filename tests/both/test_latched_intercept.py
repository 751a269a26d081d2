"""An intercepted latched output stays latched: a subscriber that joins later still gets the last message (issue 24).

A map or a robot description is published once, latched (ROS 1) or transient-local (ROS 2);
a node that takes it over publishes what its handler writes, and that must stay latched too.
"""

from __future__ import annotations

from pathlib import Path

from shell import ok
from support import wait_for

STATUS_ONCE = Path(__file__).parent / "peers" / "status_once.py"


def test_an_intercepted_latched_output_reaches_a_late_subscriber(ip, peer):
    ok(ip, "from std_msgs.msg import String\n"
           "taken = []\n"
           "def shout(msg):\n"
           "    taken.append(msg.data)\n"
           "    lw.write('status', String(data=msg.data.upper()))\n"
           f"lw = rosNode('latch_wrap')\nlw.baseNode({str(STATUS_ONCE)!r}, namespace='latch_robot')\n"
           "lw.reuse.publish('status', type=String)\n"
           "lw.new.subscribe('status', shout, msgType=String)\n"
           "lw.create()")
    try:
        wait_for(lambda: ip.user_ns["taken"], timeout=30, interval=0.1, what="the basenode's latched status")
        # three join after the one message was written (side by side: they need not take turns), each gets it
        late = [peer("listen.py", "/latch_robot/status", "std_msgs/String", "data", "--latched", f"--name=late_{i}")
                for i in range(3)]
        for one in late:
            one.wait_line("heard 'READY'", timeout=30)
        assert ip.user_ns["taken"] == ["ready"], "the basenode's message was handled once"
    finally:
        ok(ip, "lw.shutdown()")
