"""A bag rewritten (:mod:`ipyros.files.bagconvert`), pure rosbags: ROS 1 bag ↔ rosbag2 (MCAP, sqlite3), topics, a time
window, a content filter; what it refuses, in one line, leaving nothing behind."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("rosbags", reason="bash run.sh unit installs rosbags")

from rosbags.highlevel import AnyReader  # noqa: E402
from rosbags.rosbag1 import Writer  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402

from ipyros.core.errors import DeclarationError  # noqa: E402
from ipyros.files.bagconvert import convert  # noqa: E402

S = 1_000_000_000
STORE = get_typestore(Stores.ROS1_NOETIC)
TWIST, VECTOR = "geometry_msgs/msg/Twist", "geometry_msgs/msg/Vector3"


def vector(x: float):
    return STORE.types[VECTOR](x=x, y=0.0, z=0.0)


@pytest.fixture
def ros1_bag(tmp_path) -> Path:
    """20 commands, linear.x -10 .. 9, and 20 other messages, 0.1 s apart from 1000 s."""
    path = tmp_path / "in.bag"
    writer = Writer(path)
    writer.open()
    cmd = writer.add_connection("/cmd", TWIST, typestore=STORE)
    other = writer.add_connection("/other", VECTOR, typestore=STORE)
    for i in range(20):
        twist = STORE.types[TWIST](linear=vector(float(i - 10)), angular=vector(0.0))
        writer.write(cmd, 1000 * S + i * S // 10, STORE.serialize_ros1(twist, TWIST))
        writer.write(other, 1000 * S + i * S // 10, STORE.serialize_ros1(vector(1.0), VECTOR))
    writer.close()
    return path


def read(path: Path) -> list[tuple[str, int, float]]:
    with AnyReader([path]) as reader:
        return [(c.topic, stamp, reader.deserialize(raw, c.msgtype).x if c.msgtype == VECTOR else
                 reader.deserialize(raw, c.msgtype).linear.x) for c, stamp, raw in reader.messages()]


def test_a_ros1_bag_becomes_a_rosbag2_folder_and_back_with_its_stamps_and_values(ros1_bag, tmp_path):
    done = convert(ros1_bag, tmp_path / "two")
    assert (done.kept, done.read, done.topics) == (40, 40, ("/cmd", "/other"))
    assert list((tmp_path / "two").glob("*.mcap")) and (tmp_path / "two" / "metadata.yaml").exists()
    assert read(tmp_path / "two") == read(ros1_bag)
    back = convert(tmp_path / "two", tmp_path / "back.bag")
    assert back.kept == 40 and read(tmp_path / "back.bag") == read(ros1_bag)
    assert convert(tmp_path / "back.bag", tmp_path / "sq", storage="sqlite3").kept == 40
    assert list((tmp_path / "sq").glob("*.db3"))


def test_topics_a_time_window_and_a_content_filter_choose_what_is_kept(ros1_bag, tmp_path):
    seen = []

    def keep(m, topic, t):
        seen.append((topic, round(t, 3)))
        return m.linear.x > -5

    done = convert(ros1_bag, tmp_path / "kept", topics=["/cmd"], start=0.5, end=1.5, keep=keep)
    assert str(done) == f"{tmp_path / 'kept'}: 10 of 11 messages of /cmd from {ros1_bag}"
    assert seen[0] == ("/cmd", 0.5) and seen[-1] == ("/cmd", 1.5)
    assert [x for _, _, x in read(tmp_path / "kept")] == [float(x) for x in range(-4, 6)]


@pytest.mark.parametrize("options, message", [
    ({"topics": ["/nope"]}, "in.bag has no topic /nope; it has /cmd, /other"),
    ({"start": 5.0}, "--start 5: the bag lasts 1.900 s; give seconds from its start, 0 to that"),
    ({"start": 1.0, "end": 0.5}, "--end 0.5 is before --start 1"),
    ({"storage": "zip"}, "storage='zip': a rosbag2 folder stores mcap (the default) or sqlite3"),
])
def test_what_cannot_be_done_is_one_line_and_leaves_nothing(ros1_bag, tmp_path, options, message):
    with pytest.raises(DeclarationError) as raised:
        convert(ros1_bag, tmp_path / "out", **options)
    assert str(raised.value).startswith(message) and not (tmp_path / "out").exists()


def test_a_filter_that_raises_leaves_no_half_written_bag(ros1_bag, tmp_path):
    def keep(m, topic, t):
        raise ValueError("bad field")

    with pytest.raises(ValueError):
        convert(ros1_bag, tmp_path / "half", keep=keep)
    assert not (tmp_path / "half").exists()
    with pytest.raises(DeclarationError, match="exists; give a new name"):
        convert(ros1_bag, ros1_bag)
    with pytest.raises(DeclarationError, match="no bag at"):
        convert(tmp_path / "none.bag", tmp_path / "x")
