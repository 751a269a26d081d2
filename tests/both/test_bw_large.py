"""%bw says when a topic's messages are too large for the transport's defaults (issue 26): on ROS 2, Fast DDS
carries what exceeds its default shared-memory segment over UDP in fragments; ROS 1's TCPROS has no such limit."""

from __future__ import annotations

import os

from shell import ok

ON_ROS2 = os.environ.get("IPYROS_ROS") == "2"


def _bw(ip, capsys, topic: str) -> str:
    ok(ip, f"%bw {topic} -w 1.5 -n 1")
    return capsys.readouterr().out


def test_bw_names_a_topic_whose_messages_leave_fast_dds_default_shared_memory(ip, capsys):
    ok(ip, "from sensor_msgs.msg import Image\n"
           "camera = rosNode('bw_camera').new.publish('/bw_camera/big', msgType=Image)"
           ".publish('/bw_camera/small', msgType=Image).create()\n"
           "big = Image(height=300, width=1024, encoding='mono16', step=2048, data=bytes(300 * 2048))\n"
           "small = Image(height=100, width=1024, encoding='mono8', step=1024, data=bytes(100 * 1024))\n"
           "camera.timer(0.1, lambda: (camera.write('/bw_camera/big', big), camera.write('/bw_camera/small', small)))")
    capsys.readouterr()
    out = _bw(ip, capsys, "/bw_camera/small")
    assert "/bw_camera/small" in out and "KiB" not in out, out  # 100 KiB: nothing to say
    out = " ".join(_bw(ip, capsys, "/bw_camera/big /bw_camera/small").split())  # the caption wraps
    if ON_ROS2:
        assert "/bw_camera/big: messages over 512 KiB leave Fast DDS's default shared memory" in out, out
        path = os.environ["FASTDDS_DEFAULT_PROFILES_FILE"]  # folded where the line ends: compared without spaces
        assert f"FASTDDS_DEFAULT_PROFILES_FILE={path}" in out.replace(" ", ""), out
        assert "/bw_camera/small:" not in out, out
    else:
        assert "614.4" in out and "KiB" not in out, out  # the sizes are shown, nothing else said
