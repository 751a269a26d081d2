"""%echo's rostopic options: --once, --noarr, --offset (issue 25)."""

from __future__ import annotations

import re

from shell import error_of, ok


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



def test_echo_a_message_path_prints_exactly_the_values_it_selects(ip, capsys):
    """Foxglove's message paths: a field, an element from the end, a slice, a filter on the elements and one on
    the message with a variable of the user's namespace; a field that is not there says which there are."""
    ok(ip, "from geometry_msgs.msg import Pose, PoseArray\n"
           "def poses():\n"
           "    msg = PoseArray(poses=[Pose(), Pose(), Pose()])\n"
           "    msg.header.frame_id = 'map'\n"
           "    for pose, x in zip(msg.poses, (-0.5, 1.5, 2.5)):\n        pose.position.x = x\n"
           "    return msg\n"
           "paths = rosNode('echo_paths').new.publish('/echo_paths/poses', msgType=PoseArray).create()\n"
           "paths.timer(0.05, lambda: paths.write('/echo_paths/poses', poses()))\n"
           "limit = 2.0")
    capsys.readouterr()
    ok(ip, "%echo /echo_paths/poses.poses[-1].position.x -n 1")
    assert "poses[-1].position.x: 2.5\n" in capsys.readouterr().out
    ok(ip, "%echo '/echo_paths/poses.poses[:]{position.x>0}.position.x' -n 1")
    assert "poses[:]{position.x>0}.position.x:\n- 1.5\n- 2.5\n" in capsys.readouterr().out
    ok(ip, "%echo '/echo_paths/poses{header.frame_id==\"map\"}.poses[:]{position.x>=$limit}.position.x' -n 1")
    assert "position.x>=$limit}.position.x:\n- 2.5\n" in capsys.readouterr().out
    error = error_of(ip, "%echo /echo_paths/poses.poses[0].place -n 1")
    assert "geometry_msgs/Pose has no field 'place' (it has position, orientation)" in str(error), error
    error = error_of(ip, "%echo /echo_paths/poses.poses.position -n 1")  # told from the type, before a message
    assert "geometry_msgs/Pose[] is an array: index it or slice it ([0], [:]) before .position" in str(error), error


def test_echo_a_message_path_indexes_and_slices_a_uint8_array(ip, capsys):
    """/image.data[0:4]: a uint8[] is bytes on ROS 1 (it could not be indexed there) and an array on ROS 2."""
    ok(ip, "from sensor_msgs.msg import Image\n"
           "pixels = rosNode('echo_pixels').new.publish('/echo_pixels/image', msgType=Image).create()\n"
           "pixels.timer(0.05, lambda: pixels.write('/echo_pixels/image', Image(height=1, width=5, step=5, "
           "encoding='mono8', data=bytes([7, 8, 9, 250, 11]))))")
    capsys.readouterr()
    ok(ip, "%echo /echo_pixels/image.data[0:4] -n 1")
    assert "data[0:4]:\n- 7\n- 8\n- 9\n- 250\n" in capsys.readouterr().out
    ok(ip, "%echo /echo_pixels/image.data[-1] -n 1")
    assert "data[-1]: 11\n" in capsys.readouterr().out
