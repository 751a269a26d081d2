"""The README's five lines can be saved and brought back (issue 25: handler=poses.append had no source)."""

from __future__ import annotations

from shell import ok
from support import wait_for


def test_the_readmes_five_lines_save_and_load_back(ip, tmp_path, capsys):
    ok(ip, "from geometry_msgs.msg import Pose, Twist, Vector3\n"
           "poses = []\n"
           "nd = rosNode('five_lines')\n"
           "nd.new.subscribe(topic='/five/pose', handler=poses.append, msgType=Pose)"
           ".publish(topic='/five/cmd_vel', msgType=Twist).create()\n"
           "nd.timer(0.05, lambda: nd.write('/five/cmd_vel', Twist(linear=Vector3(x=2.0), angular=Vector3(z=1.8))))")
    ok(ip, "feeder = rosNode('five_feeder').new.publish('/five/pose', msgType=Pose).create()\n"
           "feeder.timer(0.05, lambda: feeder.write('/five/pose', Pose()))")
    wait_for(lambda: ip.user_ns["poses"], timeout=20, what="poses to fill")
    path = tmp_path / "five.py"
    ok(ip, f"%save_nodes {path} nd")
    text = path.read_text()
    assert "poses = list()" in text and "lambda msg: poses.append(msg)" in text, text
    ok(ip, "nd.shutdown()")
    before = ip.user_ns["poses"]
    ok(ip, f"%load_nodes {path}")
    assert ip.user_ns["nd"].created and ip.user_ns["poses"] is not before, "a new list: the data is not kept"
    wait_for(lambda: ip.user_ns["poses"], timeout=20, what="the loaded node's handler to fill the new list")
    ok(ip, "nd.shutdown(); feeder.shutdown()")
