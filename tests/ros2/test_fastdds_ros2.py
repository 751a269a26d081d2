"""Fast DDS as a session runs it: ipyros's profile (large messages in shared memory; on a local session, UDP on
loopback only) for the session and what it starts, unless the user configured Fast DDS."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from ros2_fixtures import wait_for
from sensor_msgs.msg import Image

from ipyros.dsl import engine_of
from ipyros.ros2 import fastdds


def udp_sockets(pid: int, receivers_only: bool = False) -> list[tuple[str, int]]:
    """(address, port) of the UDP sockets ``pid`` has bound: all of them, or Fast DDS's receivers alone (bound to a
    fixed port; its senders take ephemeral ports)."""
    low = int(Path("/proc/sys/net/ipv4/ip_local_port_range").read_text().split()[0])
    inodes = set()
    for fd in Path(f"/proc/{pid}/fd").iterdir():
        try:
            target = os.readlink(fd)
        except OSError:
            continue
        if target.startswith("socket:["):
            inodes.add(target[8:-1])
    found = []
    for line in Path("/proc/net/udp").read_text().splitlines()[1:]:
        fields = line.split()
        if fields[9] not in inodes:
            continue
        address, port = fields[1].split(":")
        address = ".".join(str(int(address[i:i + 2], 16)) for i in (6, 4, 2, 0))
        if not receivers_only or int(port, 16) < low:
            found.append((address, int(port, 16)))
    return found


def test_a_local_session_holds_udp_sockets_on_loopback_only(ros2_session, make_node):
    """Its receivers and its senders alike: rmw's own LOCALHOST range would add a sending socket on 0.0.0.0 and
    one on the LAN address (see ipyros/ros2/fastdds.py)."""
    make_node("fastdds_local").create()
    assert "ipyros's profile" in ros2_session.backend.transport and "loopback only" in ros2_session.backend.transport
    assert "discovery on this machine only" in ros2_session.backend.transport, "how a robot would be found: said"
    assert "discovery localhost" in ros2_session.backend.describe()
    assert udp_sockets(os.getpid(), receivers_only=True), "no DDS receivers found"
    sockets = udp_sockets(os.getpid())
    assert all(address == "127.0.0.1" for address, _ in sockets), sockets


def test_a_basenode_it_starts_holds_them_on_loopback_only_too_and_is_found(make_node):
    script = Path(__file__).resolve().parent / "peers" / "echo_node.py"
    nd = make_node("fastdds_base").baseNode(str(script))
    nd.create()  # found in the graph: discovery on loopback works both ways
    pid = nd.base.pid
    wait_for(lambda: udp_sockets(pid, receivers_only=True), timeout=20, what="the basenode's receivers")
    assert all(address == "127.0.0.1" for address, _ in udp_sockets(pid)), udp_sockets(pid)
    assert "ipyros-profile" in Path(f"/proc/{pid}/environ").read_bytes().decode(errors="replace")


def test_a_local_session_and_a_plain_localhost_node_find_each_other(make_node, tmp_path):
    """A node of the machine that ipyros did not start (rmw's own LOCALHOST range, Fast DDS's defaults) and the
    session's node hear each other: what the profile says of discovery matches what rmw does."""
    from std_msgs.msg import String

    script = tmp_path / "plain.py"
    script.write_text(PLAIN_LOCALHOST_NODE)
    env = {k: v for k, v in os.environ.items() if k not in ("FASTDDS_DEFAULT_PROFILES_FILE", fastdds.HELD_RANGE)}
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    heard = []
    nd = make_node("fastdds_meets_plain")
    nd.new.subscribe("/fastdds_plain/out", handler=lambda m: heard.append(m.data), msgType=String)
    nd.new.publish("/fastdds_plain/in", msgType=String).create()
    plain = subprocess.Popen([sys.executable, str(script)], env=env, stdout=subprocess.PIPE, text=True)
    try:
        wait_for(lambda: nd.write("/fastdds_plain/in", String(data="ping")) or heard, timeout=30, interval=0.2,
                 what="the plain node to answer")
    finally:
        plain.terminate()
        try:
            plain.wait(10)
        except subprocess.TimeoutExpired:  # rclpy's teardown after SIGTERM, on a loaded machine: not under test
            plain.kill()
            plain.wait(10)
        plain.stdout.close()
    assert heard[0] == "pong: ping"


PLAIN_LOCALHOST_NODE = """
import rclpy
from rclpy.node import Node
from std_msgs.msg import String
rclpy.init()
node = Node("plain_localhost")
out = node.create_publisher(String, "/fastdds_plain/out", 10)
node.create_subscription(String, "/fastdds_plain/in", lambda m: out.publish(String(data="pong: " + m.data)), 10)
try:
    rclpy.spin(node)
except Exception:
    pass
"""


def test_a_users_own_fast_dds_profile_is_left_alone(tmp_path):
    mine = tmp_path / "mine.xml"
    mine.write_text('<?xml version="1.0"?><dds xmlns="http://www.eprosima.com"><profiles/></dds>')
    code = ("from ipyros.ros2 import fastdds; import os; print(fastdds.prepare()); "
            "print(os.environ['FASTDDS_DEFAULT_PROFILES_FILE'])")
    env = {**os.environ, "FASTDDS_DEFAULT_PROFILES_FILE": str(mine)}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=60).stdout
    assert f"Fast DDS as you configured it (FASTDDS_DEFAULT_PROFILES_FILE={mine}; discovery" in out and str(mine) in out


def test_a_large_best_effort_topic_is_delivered(make_node, peer):
    """With Fast DDS's default 512 KiB shared-memory segment, a best-effort 1 MiB image delivered nothing."""
    listener = peer("listen.py", "/fastdds/image", "sensor_msgs/Image", "header.frame_id", "--best-effort")
    listener.wait_line("ready")
    nd = make_node("fastdds_camera").new.publish("/fastdds/image", msgType=Image, qos="sensor_data").create()
    wait_for(lambda: engine_of(nd).sent()[0].connections, timeout=20, what="the listener")
    image = Image(height=1024, width=1024, encoding="mono8", step=1024, data=bytes(1 << 20))
    sent = 0

    def heard_ten() -> bool:  # best effort may drop some on a loaded machine; the default profile dropped all
        nonlocal sent
        image.header.frame_id = str(sent)
        nd.write("/fastdds/image", image)
        sent += 1
        return sum(line.startswith("heard") for line in listener.lines) >= 10

    wait_for(heard_ten, timeout=30, interval=0.05, what="ten 1 MiB images sent best effort")


def test_fast_dds_files_nobody_uses_are_removed_and_used_ones_kept():
    """What a killed participant leaves in /dev/shm is removed before a session starts; a file that a living
    process maps or holds open (the session's own, a peer's) is kept. Files of the test's own, by name."""
    import mmap

    stale, mapped, held = (fastdds.SHM / f"fastdds_ipyros_test_{os.getpid()}_{what}"
                           for what in ("stale", "mapped", "held"))
    for path in (stale, mapped, held):
        path.write_bytes(b"\0" * 4096)
    try:
        with open(mapped, "r+b") as f, open(held, "rb"):
            view = mmap.mmap(f.fileno(), 4096)
            f.close()  # mapped, no longer open: as Fast DDS keeps its ports
            try:
                removed = fastdds.remove_stale_files({stale.name, mapped.name, held.name})
            finally:
                view.close()
        assert removed == [stale.name]
        assert not stale.exists() and mapped.exists() and held.exists()
    finally:
        for path in (stale, mapped, held):
            path.unlink(missing_ok=True)


def test_a_session_that_sent_goals_deletes_its_participants_when_it_closes():
    """A closed session holds no Fast DDS participant, action clients included: one still held when the process
    ends leaves its ports in /dev/shm (the order Python frees things in at exit decides). What it made is unmapped
    once it closed; the segments of others it wrote to (this pytest's) stay mapped in Fast DDS's process-wide cache."""
    program = """
from pathlib import Path

import pytest
from ipyros.node import session as sessions
from ipyros.dsl import rosNode
others = set(str(p) for p in Path("/dev/shm").iterdir())
session = sessions.configure(sessions.SessionConfig(start_master=False))
server = rosNode("leak_server").new.action("/leak/count", "test_msgs/Fibonacci", lambda goal, action: {"sequence": [1]})
server.create()
client = rosNode("leak_client").create()
assert list(client.send_goal("/leak/count", {"order": 1}).result(timeout=20).sequence) == [1]
session.close()
print("mapped:", sorted({line.split()[-1] for line in Path("/proc/self/maps").read_text().splitlines()
                         if "/fastdds_" in line} - others))
"""
    done = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0 and "mapped:" in done.stdout, done.stderr[-2000:]
    assert "mapped: []" in done.stdout, done.stdout


@pytest.mark.parametrize("env, words", [
    ({"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}, "discovery on this machine only"),
    ({"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET"}, "discovery on the subnet (multicast)"),
    ({"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET", "ROS_STATIC_PEERS": "198.18.0.2"},
     "discovery on the subnet (multicast) and the static peers 198.18.0.2"),
    ({"ROS_DISCOVERY_SERVER": "198.18.0.2:11811"}, "discovery through the server at 198.18.0.2:11811"),
])
def test_the_load_line_says_how_peers_are_found(monkeypatch, env, words):
    """A robot on another machine is found only if discovery reaches it: the load line says how it goes."""
    for name in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_LOCALHOST_ONLY", "ROS_STATIC_PEERS", "ROS_DISCOVERY_SERVER",
                 fastdds.HELD_RANGE):
        monkeypatch.delenv(name, raising=False)
    for name, value in env.items():
        monkeypatch.setenv(name, value)
    assert words in fastdds.discovery_words()
