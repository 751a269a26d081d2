"""Writing never loses data silently and never blocks: rejected messages, slow subscribers."""

from __future__ import annotations

import time

import pytest
from peer import Peer
from ros1_fixtures import wait_for
from shell import error_of, ok
from std_msgs.msg import Header, UInt32

from ipyros.core.errors import MessageTypeError


def last_x(peer: Peer) -> float | None:
    """The linear.x of the last Twist the echo peer printed."""
    for line in reversed(peer.lines):
        if "linear:" in line:
            return float(line.split("x:")[1].split()[0])
    return None


def test_a_rejected_write_leaves_every_connection_as_it_was(make_node):
    from geometry_msgs.msg import Twist, Vector3

    nd = make_node("rejecting")
    nd.new.publish("/reject/cmd", msgType=Twist).create()
    with Peer("echo_topic.py", "/reject/cmd", "geometry_msgs/Twist") as peer:
        peer.wait_line("ready")

        def delivered(x: float) -> bool:
            nd.write("/reject/cmd", Twist(linear=Vector3(x=x)))
            return last_x(peer) == x

        wait_for(lambda: delivered(1.0), timeout=20, what="the peer to get a first message")
        bad = Twist()
        bad.linear.x = "fast"
        with pytest.raises(MessageTypeError, match=r"cannot send this geometry_msgs/Twist on /reject/cmd: .*"
                                                   r"nothing was sent"):
            nd.write("/reject/cmd", bad)
        with pytest.raises(MessageTypeError, match="carries geometry_msgs/Twist, not the class geometry_msgs/Twist"):
            nd.write("/reject/cmd", Twist)
        nd.write("/reject/cmd", Twist(linear=Vector3(x=2.0)))
        wait_for(lambda: last_x(peer) == 2.0, timeout=5, what="the next good message after the rejected ones")
        got = [line for line in peer.lines if line != "ready"]
        assert all("x: 1.0" in line for line in got[:-1]) and "x: 2.0" in got[-1], got


def test_a_pub_that_cannot_be_serialized_breaks_nothing(ip, capsys):
    with Peer("echo_topic.py", "/reject/stamp", "std_msgs/Time") as peer:
        peer.wait_line("ready")
        ok(ip, "%pub /reject/stamp std_msgs/Time {data: 5}")
        peer.wait_line("secs: 5")
        error = error_of(ip, "%pub /reject/stamp std_msgs/Time {data: 99999999999}")  # caught when built
        assert isinstance(error, MessageTypeError) and "does not fit a time" in str(error)
        # nsecs carried into secs overflow only when serialised: caught there, before any connection
        error = error_of(ip, "%pub /reject/stamp std_msgs/Time {data: {secs: 4294967295, nsecs: 2000000000}}")
        assert isinstance(error, MessageTypeError) and "nothing was sent" in str(error)
        ok(ip, "%pub /reject/stamp std_msgs/Time {data: 7}")
        peer.wait_line("secs: 7")


def test_a_slow_subscriber_blocks_neither_the_writer_nor_the_others(make_node):
    """1 MiB images at 20 Hz, one subscriber asleep in its callback: write() stays fast, the
    other subscriber gets them all, and the slow one's dropped messages are counted."""
    from sensor_msgs.msg import Image

    nd = make_node("imaging")
    nd.new.publish("/slow/image", msgType=Image).create()
    image = Image(height=512, width=512, encoding="mono32", step=2048, data=bytes(1 << 20))
    with Peer("count_topic.py", "/slow/image", "sensor_msgs/Image", "--sleep", "30") as slow, \
            Peer("count_topic.py", "/slow/image", "sensor_msgs/Image") as fast:
        slow.wait_line("ready")
        fast.wait_line("ready")
        wait_for(lambda: nd.status().row("/slow/image").connections == 2, timeout=20,
                 what="both subscribers to connect")
        for _ in range(60):
            nd.write("/slow/image", image)
            time.sleep(0.05)  # 20 Hz, as a camera sends
        # All 60 got through to the fast one while the slow one is still in its first 30 s callback:
        # the writes did not wait for it.
        fast.wait_line("got 60", timeout=20)
        row = nd.status().row("/slow/image")
        assert row.calls == 60 and row.dropped > 0, row
        assert "got 2" not in slow.lines, "the slow peer is still in its first callback"


def test_a_publisher_that_closes_and_reopens_its_topic_is_followed(make_node):
    """rospy drops a publisher for good when it unregisters and advertises again faster than the
    master's updates arrive (the old connection is still listed when the new update comes, then
    ends): the subscription asks the master again whenever a connection ends."""
    heard = []
    make_node("reopen_listener").new.subscribe("/reopen", handler=lambda m: heard.append(m.data),
                                               msgType=UInt32).create()
    with Peer("reopen_topic.py", "/reopen") as peer:
        peer.wait_line("ready")
        wait_for(lambda: heard, timeout=20, what="the first messages")
        for n in range(1, 16):
            peer.proc.stdin.write("reopen\n")
            peer.proc.stdin.flush()
            peer.wait_line(f"reopened {n}")
            count = len(heard)
            wait_for(lambda: len(heard) > count + 5, timeout=10, what=f"messages after reopen {n}")


def test_a_subscriber_slower_than_the_writer_but_reading_loses_nothing(make_node):
    """Flat out, 1 MiB images are written faster than a rospy subscriber takes them: its backlog fills,
    and write() waits for room (as it would behind a direct connection) instead of dropping."""
    import re

    from sensor_msgs.msg import Image

    nd = make_node("flat_out")
    nd.new.publish("/flat/image", msgType=Image).create()
    with Peer("check_images.py", "/flat/image") as checker:
        checker.wait_line("ready")
        wait_for(lambda: nd.status().row("/flat/image").connections == 1, timeout=20, what="the checker to connect")
        size = 1 << 20
        for i in range(1, 151):
            nd.write("/flat/image", Image(height=1, width=size, encoding="mono8", step=size,
                                          data=bytes([i % 251]) * size, header=Header(frame_id=str(i))))
        wait_for(lambda: any(line.startswith("got 150 ") for line in checker.lines), timeout=60,
                 what=f"all 150 images (dropped: {nd.status().row('/flat/image').dropped})")
        ids = [int(m.group(1)) for line in checker.lines if (m := re.fullmatch(r"got \d+ (\d+)", line))]
        assert ids == list(range(1, 151)) and not any(line.startswith("broken") for line in checker.lines)
        assert nd.status().row("/flat/image").dropped == 0
