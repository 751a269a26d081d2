"""An MCAP file of ROS 1 messages read with mcap alone (:mod:`ipyros.ros1.mcapread`: what the bag player reads
without ipyros, and :mod:`ipyros.ros1.mcapfile` with one-line errors), on a file written by ``%record``'s writer."""

from __future__ import annotations

import pytest
from geometry_msgs.msg import Twist, Vector3
from std_msgs.msg import UInt32

from ipyros.core.errors import DeclarationError
from ipyros.ros1 import mcapfile, mcapread

S = 10**9


@pytest.fixture
def recorded(tmp_path):
    path = tmp_path / "run.mcap"
    writer = mcapfile.McapWriter(path)
    for i in range(1, 6):
        writer.write("/count", UInt32(data=i), stamp=100 * S + i * S)
    writer.write("/cmd_vel", Twist(linear=Vector3(x=0.5)), stamp=103 * S + S // 2)
    writer.close()
    return path


def test_the_summary_span_and_classes_come_from_the_file_itself(recorded):
    summary = mcapread.summary(recorded)
    assert mcapread.span(summary) == (101 * S, 105 * S)
    classes = mcapread.message_classes(summary)
    assert set(classes) == {"/count", "/cmd_vel"}
    assert classes["/count"]._type == "std_msgs/UInt32" and classes["/count"]._md5sum == UInt32._md5sum
    assert set(mcapread.message_classes(summary, ["/cmd_vel"])) == {"/cmd_vel"}


def test_messages_come_in_recorded_order_from_a_start_on(recorded):
    read = [(topic, stamp, getattr(msg, "data", None)) for topic, stamp, msg in mcapread.messages(recorded)]
    assert [stamp for _, stamp, _ in read] == sorted(stamp for _, stamp, _ in read) and len(read) == 6
    later = list(mcapread.messages(recorded, ["/count"], start=104 * S))
    assert [(stamp, msg.data) for _, stamp, msg in later] == [(104 * S, 4), (105 * S, 5)]


def test_what_is_no_mcap_file_is_one_line_in_the_session(tmp_path):
    bad = tmp_path / "run.mcap"
    bad.write_bytes(b"not an MCAP file")
    with pytest.raises(DeclarationError, match=r"^cannot read the MCAP file .*run\.mcap: "):
        mcapfile.mcap_info(bad)
    with pytest.raises(DeclarationError, match=r"^cannot read the MCAP file"):
        mcapfile.mcap_messages(bad)  # at once, not at the first message
