"""Large messages are read straight into one buffer, and through a relay go on while they arrive
(ipyros.ros1.cutthrough): a handler gets each one whole and in order, so does every subscriber of a relay,
and a publisher cut off in the middle of a message breaks no subscriber: the cut message is counted as
dropped and the next ones arrive."""

from __future__ import annotations

import re

from ros1_fixtures import Peer, wait_for
from sensor_msgs.msg import Image

from ipyros.core.plan import internal_name


def wrapped_camera(make_node, name: str, topic: str):
    """A wrapping node that relays ``topic`` unchanged; its source (the internal name) is returned too."""
    w = make_node(name)
    w.baseNode("echo_node").basePackage("ipyros_test_nodes")  # publishes nothing on topic: peers do
    w.reuse.publish(topic=topic, type=Image)
    w.create()
    return w, internal_name(w.model(), topic)


def received(checker: Peer) -> list[int]:
    """The frame ids of the whole images the checker got, in order; broken ones fail the test."""
    assert not [line for line in checker.lines if line.startswith("broken")], checker.lines[-5:]
    return [int(m.group(1)) for line in checker.lines if (m := re.fullmatch(r"got \d+ (\d+)", line))]


def test_a_handler_gets_large_images_whole_and_in_order(make_node):
    parsed = []

    def check(m: Image) -> None:
        i = int(m.header.frame_id)
        parsed.append((i, type(m.data), m.data == bytes([i % 251]) * (1 << 20)))

    make_node("large_reader").new.subscribe("/large/image", msgType=Image, handler=check).create()
    with Peer("publish_images.py", "/large/image", "--rate", "20", "--count", "20", "--when-heard"):
        wait_for(lambda: len(parsed) == 20, timeout=60, what="20 images through the handler")
    assert parsed == [(i, bytes, True) for i in range(1, 21)], parsed


def test_large_images_reach_every_subscriber_whole_and_in_order(make_node):
    w, source = wrapped_camera(make_node, "cut_camera", "/cut/image")
    with Peer("check_images.py", "/cut/image") as first, Peer("check_images.py", "/cut/image") as second:
        first.wait_line("ready")
        second.wait_line("ready")
        wait_for(lambda: w.status().row("/cut/image").connections == 2, timeout=20, what="both checkers to connect")
        with Peer("publish_images.py", source, "--rate", "20"):
            for checker in (first, second):
                wait_for(lambda: len(received(checker)) >= 20, timeout=60, what="20 whole images")
            # A handler reading the relay's source too: it parses the same messages (as bytes, as rospy's are).
            parsed = []
            make_node("cut_reader").new.subscribe(
                source, msgType=Image,
                handler=lambda m: parsed.append((int(m.header.frame_id), type(m.data), m.data[:1], len(m.data)))
            ).create()
            wait_for(lambda: len(parsed) >= 10, timeout=60, what="the handler to parse 10 images")
            start = len(received(first))
            wait_for(lambda: len(received(first)) >= start + 10, timeout=60, what="10 more images with the handler")
    for checker in (first, second):
        ids = received(checker)
        assert ids == list(range(ids[0], ids[0] + len(ids))), f"lost or out of order: {ids}"
    assert all(kind is bytes and first_byte == bytes([i % 251]) and size == 1 << 20
               for i, kind, first_byte, size in parsed), parsed[:3]
    assert w.status().row("/cut/image").dropped == 0


def test_a_publisher_cut_off_in_mid_image_breaks_no_subscriber(make_node):
    w, source = wrapped_camera(make_node, "cutoff_camera", "/cutoff/image")
    with Peer("check_images.py", "/cutoff/image") as checker:
        checker.wait_line("ready")
        wait_for(lambda: w.status().row("/cutoff/image").connections == 1, timeout=20, what="the checker to connect")
        with Peer("cut_publisher.py", source) as cut:
            cut.wait_line("half sent")
            checker.wait_line("got 1 1")  # the first image went through whole
            cut.proc.stdin.write("cut\n")
            cut.proc.stdin.flush()
            cut.wait_line("cut")
            wait_for(lambda: w.status().row("/cutoff/image").dropped == 1, timeout=20,
                     what="the image cut in half to be counted as dropped")
        # The checker's stream was cut mid-image: its connection was closed, and it is told to connect again.
        with Peer("publish_images.py", source, "--rate", "20", "--first", "100"):
            wait_for(lambda: len(received(checker)) >= 6, timeout=60, what="whole images after the cut")
    ids = received(checker)
    assert ids[0] == 1 and all(i >= 100 for i in ids[1:]), ids


def test_a_slow_subscriber_holds_up_neither_the_relay_nor_the_others(make_node):
    """Images sent on in pieces wait, for a subscriber asleep in its callback, in that connection's own
    backlog (whole ones dropped and counted when it is full, none cut): the other one gets them all."""
    w, source = wrapped_camera(make_node, "slow_camera", "/slowcut/image")
    with Peer("count_topic.py", "/slowcut/image", "sensor_msgs/Image", "--sleep", "30") as slow, \
            Peer("check_images.py", "/slowcut/image") as fast:
        slow.wait_line("ready")
        fast.wait_line("ready")
        wait_for(lambda: w.status().row("/slowcut/image").connections == 2, timeout=20,
                 what="both subscribers to connect")
        with Peer("publish_images.py", source, "--rate", "20", "--count", "60", "--when-heard"):
            wait_for(lambda: len(received(fast)) == 60, timeout=60, what="all 60 images to the fast subscriber")
        ids = received(fast)
        assert ids == list(range(1, 61)), ids
        assert w.status().row("/slowcut/image").dropped > 0
        assert "got 2" not in slow.lines, "the slow peer is still in its first callback"
