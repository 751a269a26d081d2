"""A guarded relay reads a message's numbers in its bytes (:mod:`ipyros.core.wire`): on each ROS, for common types
filled at random (strings of every length, so that CDR's padding moves), the numbers read in the bytes the ROS
serialised are the message's own, and the gate's check of the bytes agrees with its check of the message."""

from __future__ import annotations

import importlib.util
import io
import math
import random
import string

import pytest

from ipyros.core import wire
from ipyros.core.guard import Acting, Gate
from ipyros.core.msgbuild import field_types, nested_class

ROS2 = importlib.util.find_spec("rospy") is None
ENCODING = wire.CDR if ROS2 else wire.ROS1
TYPES = ["geometry_msgs/Twist", "geometry_msgs/TwistStamped", "sensor_msgs/LaserScan", "sensor_msgs/JointState",
         "sensor_msgs/Imu", "sensor_msgs/Joy", "sensor_msgs/Image", "geometry_msgs/PoseWithCovarianceStamped",
         "sensor_msgs/BatteryState", "sensor_msgs/Range", "sensor_msgs/NavSatFix"]
INTS = {"int8": 7, "uint8": 8, "int16": 15, "uint16": 16, "int32": 31, "uint32": 32, "int64": 63, "uint64": 64}


def serialize(msg) -> bytes:
    if ROS2:
        from rclpy.serialization import serialize_message

        return serialize_message(msg)
    buffer = io.BytesIO()
    msg.serialize(buffer)
    return buffer.getvalue()


def fill(msg, rng: random.Random) -> None:
    """Each field of ``msg`` at random: numbers, strings of 0 to 7 letters, sequences of 0 to 4 elements."""
    for name, kind in zip(*field_types(type(msg))):
        base, _, size = kind.partition("[")
        size = size.rstrip("]")
        count = int(size) if size else rng.randrange(5)

        def one():
            if base in ("float32", "float64"):
                return rng.choice([rng.uniform(-1e3, 1e3), 0.0, -0.0, 1e-310 if base == "float64" else 1e-40])
            if base in INTS:
                bits = INTS[base]
                return rng.randrange(0, 1 << bits) if base.startswith("u") else rng.randrange(-(1 << bits), 1 << bits)
            if base == "bool":
                return rng.random() < 0.5
            if base == "string":
                return "".join(rng.choice(string.ascii_letters) for _ in range(rng.randrange(8)))
            return None

        if base in ("time", "duration"):
            setattr(msg, name, type(getattr(msg, name))(rng.randrange(1 << 30), rng.randrange(10 ** 9)))
        elif "[" in kind:
            if nested_class(base) is not None and one() is None:
                continue  # an array of messages: left empty
            values = [one() for _ in range(count)]
            setattr(msg, name, bytes(values) if base == "uint8" and not ROS2 else values)
        elif one() is None:
            fill(getattr(msg, name), rng)
        else:
            setattr(msg, name, one())


def value_at(msg, name: str):
    for part in name.split("."):
        field, _, index = part.partition("[")
        msg = getattr(msg, field)
        if index:
            msg = msg[int(index.rstrip("]"))]
    return msg


@pytest.mark.parametrize("type_name", TYPES)
def test_the_numbers_read_in_the_bytes_are_the_messages_own(type_name):
    from ipyros.core.msgtypes import resolve_message

    cls = resolve_message(type_name)[1]
    layout = wire.layout(cls, ENCODING)
    assert layout is not None and layout.names, type_name
    rng = random.Random(type_name)
    for _ in range(200):
        msg = cls()
        fill(msg, rng)
        read = layout.read(serialize(msg))
        assert read is not None, msg
        expected = [value_at(msg, name) for name in layout.names]
        assert [pytest.approx(v, rel=1e-6, abs=1e-45) if isinstance(v, float) else v for v in expected] == read


def test_a_nan_in_a_sequence_or_a_field_is_found_in_the_bytes():
    from ipyros.core.msgtypes import resolve_message

    cls = resolve_message("sensor_msgs/LaserScan")[1]
    layout = wire.layout(cls, ENCODING)
    scan = cls()
    scan.header.frame_id = "laser"
    scan.ranges = [1.0, 2.0, 3.0]
    assert layout.read(serialize(scan)) is not None
    scan.ranges = [1.0, math.nan, 3.0]
    assert layout.read(serialize(scan)) is None
    scan.ranges, scan.range_max = [1.0], math.inf
    assert layout.read(serialize(scan)) is None


def test_the_gate_passes_in_the_bytes_exactly_what_it_passes_as_it_came_in_the_message():
    """Hostile Twists: the check of the bytes passes a message if and only if the check of the message passes it
    unchanged; anything else is read whole, so clamping and the stop message stay the object check's."""
    from ipyros.core.msgtypes import resolve_message

    cls = resolve_message("geometry_msgs/TwistStamped")[1]
    limits = {"twist.linear.x": (-0.5, 0.5), "twist.angular.z": (-1.0, 1.0)}

    def made() -> Gate:
        return Gate("/cmd_vel", cls, limits, {}, "clamp", cls, lambda: False, lambda: None, lambda text: None)

    raw_gate, gate = made(), made()
    passes = raw_gate.raw_checker(ENCODING)
    hostile = [math.nan, math.inf, -math.inf, 1e308, -0.0, 0.0, 0.5, 0.5000001, -0.5, -1.0, 1.0, 1.0000001, 0.2]
    rng = random.Random(52)
    for n in range(3000):
        msg = cls()
        msg.header.frame_id = "base" * rng.randrange(3)
        msg.twist.linear.x, msg.twist.linear.y, msg.twist.angular.z = (rng.choice(hostile) for _ in range(3))
        as_it_came = gate.check(msg).acting is Acting.PASSED
        assert passes(serialize(msg)) == as_it_came, msg
    assert raw_gate.figures.passed == gate.figures.passed - gate.figures.replaced - gate.figures.clamped
