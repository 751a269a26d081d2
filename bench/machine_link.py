"""The robot as another machine: how soon a lost link stops the robot, and that a lossy one does not.

    python -m bench.machine_link            # 50 link cuts, 60 s at 10 % loss (about 4 minutes)
    python -m bench.machine_link --quick    # 10 cuts, 20 s of loss

Either ROS, as root (network namespaces; ``tests/both/test_machine_link.py`` runs the same setup): the bench
makes a robot's namespace joined to this one by a veth pair (addresses from the benchmarking range
198.18.0.0/15), and runs there a rosmaster, a keeper (``python -m ipyros.machine``) and a plain
subscriber standing for the motors; here, a session whose node drives ``/link/cmd_vel`` at 20 Hz through
a guard placed on the robot (lease 0.5 s).

**Link cut to the stop message**: the link is cut (``ip link set ... down``) while commands flow; the
figure is the time from the cut to the first stop message at the motors (one clock: the kernel's
monotonic one, shared by the namespaces), p50 and p99 over the cuts; the link comes back and the bench
waits until commands reach the motors again before the next cut. Target (issue 48): p99 within the
lease + 50 ms.

**A lossy link**: 10 % of the packets each way across the veth dropped (nftables on the robot's end;
this kernel has no netem) while the session drives: stop messages at the motors, target 0.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import re
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterator, Optional

from bench.figures import Figure, keep, machine, table, target_lines
from bench.relay import BenchError, free_port, percentile, stop_cleanly_on_sigterm, wait_until

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
LISTEN = REPO / "tests" / "both" / "peers" / "listen_twist.py"
RESULTS = HERE / "results"
LEASE = 0.5
MARGIN_MS = 50.0
TOPIC = "/link/cmd_vel"

SESSION = f"""
import time
from ipyros import rosNode
from geometry_msgs.msg import Twist
nd = rosNode("laptop")
nd.new.publish("{TOPIC}", msgType=Twist, qos="best_effort")  # ROS 2: commands are not held up behind a lost one
nd.guard("{TOPIC}", limits={{"linear.x": (-0.5, 0.5)}}, machine="linkbot", lease={LEASE}, grace=0.5)
nd.create()
print("created", flush=True)
m = Twist()
m.linear.x = 0.3
while True:
    nd.write("{TOPIC}", m)
    time.sleep(0.05)
"""


class Proc:
    """A process (``ip netns exec`` becomes it) with the environment ``env`` (the whole of it), its lines read as it
    prints them."""

    def __init__(self, argv: list[str], env: dict[str, str]) -> None:
        self.proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                     text=True, env={**env, "PYTHONUNBUFFERED": "1"})
        self.lines: list[str] = []
        threading.Thread(target=lambda: self.lines.extend(line.rstrip("\n") for line in self.proc.stdout),
                         daemon=True).start()

    def wait_line(self, text: str, timeout: float = 60.0) -> str:
        """The first line holding ``text``; a :class:`BenchError` with its last lines if it ends or takes too long."""
        def found() -> Optional[str]:
            line = next((line for line in list(self.lines) if text in line), None)
            if line is None and self.proc.poll() is not None:
                raise BenchError(f"it ended ({self.proc.returncode}) before {text!r}")
            return line

        try:
            return wait_until(found, timeout, repr(text), 0.05)
        except BenchError as error:
            raise BenchError(f"{error}; it printed: {' | '.join(self.lines[-5:]) or 'nothing'}") from None

    def stop(self) -> None:
        for ask, wait in ((signal.SIGINT, 10.0), (signal.SIGKILL, 10.0)):
            if self.proc.poll() is None:
                self.proc.send_signal(ask)
                try:
                    self.proc.wait(wait)
                except subprocess.TimeoutExpired:
                    continue


def ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True, timeout=30)


def net(pid: object) -> str:
    """The network namespace a process is in (``net:[4026532177]``)."""
    return os.readlink(f"/proc/{pid}/ns/net")


def twists(motors: Proc) -> list[tuple[float, float]]:
    """``(linear.x, when)`` of each message the motors heard."""
    return [(float(line.split()[1]), float(line.split()[4])) for line in list(motors.lines)
            if line.startswith("twist ")]


@dataclass
class Link:
    """The robot's network namespace and the veth pair to it: each end's interface and address."""

    ns: str
    here: str
    there: str
    laptop: str
    robot: str


@contextmanager
def robot_link() -> Iterator[Link]:
    """A robot's namespace joined to this one by a veth pair (198.18.x.0/30), gone afterwards."""
    pid = os.getpid()
    tag = pid % 200 + 20
    link = Link(f"ipyros_robot_{pid}", f"ipyl{pid}"[:15], f"ipyr{pid}"[:15], f"198.18.{tag}.1", f"198.18.{tag}.2")
    ip("netns", "add", link.ns)
    try:
        ip("link", "add", link.here, "type", "veth", "peer", "name", link.there)
        ip("link", "set", link.there, "netns", link.ns)
        ip("addr", "add", f"{link.laptop}/30", "dev", link.here)
        ip("link", "set", link.here, "up")
        ip("-n", link.ns, "addr", "add", f"{link.robot}/30", "dev", link.there)
        ip("-n", link.ns, "link", "set", link.there, "up")
        ip("-n", link.ns, "link", "set", "lo", "up")
        yield link
    finally:
        subprocess.run(["ip", "link", "del", link.here], capture_output=True, timeout=30)
        subprocess.run(["ip", "netns", "del", link.ns], capture_output=True, timeout=30)


@dataclass
class Placed:
    """What runs on each side: the robot's keeper and motors, the laptop's session driving them at 20 Hz through a
    guard placed on the robot; ``on_laptop``: a laptop process's environment (for more sessions)."""

    link: Link
    keeper: Proc
    motors: Proc
    session: Proc
    on_laptop: dict[str, str]
    on_robot: dict[str, str]


def ros_name() -> str:
    """The ROS of this venv: ROS 1 where rospy is, else ROS 2."""
    return "ROS 1" if importlib.util.find_spec("rospy") is not None else "ROS 2"


@contextmanager
def placed(link: Link, workdir: Path, allow: tuple[str, ...] = (), discovery_port: Optional[int] = None
           ) -> Iterator[Placed]:
    """The keeper (allowing ``allow``) and the motors in the robot's namespace (ROS 1: its master too; ROS 2: a
    domain of its own, discovered across the link: SUBNET, or through the keeper's discovery server on
    ``discovery_port``), the token copied to the laptop as an SSH key is, and the session driving the motors; all
    stopped afterwards."""
    keep = {k: v for k, v in os.environ.items() if not k.startswith("ROS_") or k == "ROS_PACKAGE_PATH"}
    keep["PYTHONPATH"] = os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH")) if p)
    # the bench's stand-in basenode's package (ipyros_bench/idle), found on the robot as rosrun finds it
    keep["ROS_PACKAGE_PATH"] = os.pathsep.join(p for p in (str(HERE / "nodes"), keep.get("ROS_PACKAGE_PATH")) if p)
    in_ns = ["ip", "netns", "exec", link.ns]
    started: list[Proc] = []
    if ros_name() == "ROS 1":
        port = free_port()
        master = f"http://{link.robot}:{port}/"
        on_robot = {**keep, "ROS_MASTER_URI": master, "ROS_IP": link.robot}
        on_laptop = {**keep, "ROS_MASTER_URI": master, "ROS_IP": link.laptop}
        started.append(Proc([*in_ns, "rosmaster", "--core", "-p", str(port), "-w", "3"], on_robot))
    else:  # a domain of its own, found across the veth: each process's Fast DDS profile its own (not the loopback
        # one a test session made), as on two machines
        keep = {k: v for k, v in keep.items() if not k.startswith(("FASTDDS_", "FASTRTPS_", "IPYROS_", "RMW_"))}
        domain = {**keep, "IPYROS_ROS": "2", "ROS_DOMAIN_ID": str(150 + os.getpid() % 80),
                  "ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET"}
        on_robot, on_laptop = dict(domain), dict(domain)
        if discovery_port is not None:  # the keeper starts the server; the motors and the laptop are its clients
            on_robot["ROS_DISCOVERY_SERVER"] = f"127.0.0.1:{discovery_port}"
            on_laptop["ROS_DISCOVERY_SERVER"] = f"{link.robot}:{discovery_port}"
    on_robot["ROS_HOME"], on_laptop["ROS_HOME"] = str(workdir / "robot"), str(workdir / "laptop")
    try:
        keeper = Proc([*in_ns, sys.executable, "-m", "ipyros.machine", "--name", "linkbot",
                       *(f"--allow={package}" for package in allow),
                       *(("--discovery-server", str(discovery_port)) if discovery_port is not None else ())], on_robot)
        started.append(keeper)
        keeper.wait_line(f"ipyros machine linkbot ready on {ros_name()}")
        motors = Proc([*in_ns, sys.executable, str(LISTEN), TOPIC, "--name=motors"], on_robot)
        started.append(motors)
        motors.wait_line("ready")
        token = workdir / "laptop" / "ipyros" / "machines" / "linkbot.token"
        token.parent.mkdir(parents=True)
        token.write_bytes((workdir / "robot" / "ipyros" / "machines" / "linkbot.token").read_bytes())
        token.chmod(0o600)
        script = workdir / "laptop.py"
        script.write_text(SESSION)
        session = Proc([sys.executable, str(script)], on_laptop)
        started.append(session)
        session.wait_line("created")
        wait_until(lambda: sum(x == 0.3 for x, _ in twists(motors)) >= 10, 30, "commands at the motors", 0.05)
        yield Placed(link, keeper, motors, session, on_laptop, on_robot)
    finally:
        for proc in reversed(started):
            proc.stop()


@contextmanager
def no_multicast(link: Link) -> Iterator[Callable[[], int]]:
    """No multicast across the link, either way (as many Wi-Fi networks): nftables on the robot's end; what it
    gives: how many packets it dropped so far."""
    table_ = "ipyros_no_multicast"
    rules = f"""table inet {table_} {{
        chain in {{ type filter hook input priority 0; policy accept;
                    iifname "{link.there}" ip daddr 224.0.0.0/4 counter drop; }}
        chain out {{ type filter hook output priority 0; policy accept;
                     oifname "{link.there}" ip daddr 224.0.0.0/4 counter drop; }}
    }}"""
    in_ns = ["ip", "netns", "exec", link.ns, "nft"]
    subprocess.run([*in_ns, "-f", "-"], input=rules, text=True, check=True, capture_output=True, timeout=30)

    def dropped() -> int:
        listed = subprocess.run([*in_ns, "list", "table", "inet", table_], text=True, capture_output=True,
                                timeout=30).stdout
        return sum(int(n) for n in re.findall(r"counter packets (\d+)", listed))

    try:
        yield dropped
    finally:
        subprocess.run([*in_ns, "delete", "table", "inet", table_], capture_output=True, timeout=30)


@contextmanager
def lossy(link: Link, percent: int = 10) -> Iterator[Callable[[], list[int]]]:
    """``percent`` % of the packets each way across the link dropped (nftables on the robot's end; this kernel has
    no netem) while in the block; what it gives: how many it dropped each way so far."""
    table_ = "ipyros_loss"
    rules = f"""table inet {table_} {{
        chain in {{ type filter hook input priority 0; policy accept;
                    iifname "{link.there}" numgen random mod 100 < {percent} counter drop; }}
        chain out {{ type filter hook output priority 0; policy accept;
                     oifname "{link.there}" numgen random mod 100 < {percent} counter drop; }}
    }}"""
    in_ns = ["ip", "netns", "exec", link.ns, "nft"]
    subprocess.run([*in_ns, "-f", "-"], input=rules, text=True, check=True, capture_output=True, timeout=30)

    def dropped() -> list[int]:
        listed = subprocess.run([*in_ns, "list", "table", "inet", table_], text=True, capture_output=True,
                                timeout=30).stdout
        return [int(n) for n in re.findall(r"counter packets (\d+)", listed)]

    try:
        yield dropped
    finally:
        subprocess.run([*in_ns, "delete", "table", "inet", table_], capture_output=True, timeout=30)


def cuts(link: Link, motors: Proc, count: int) -> list[float]:
    """``count`` link cuts: the ms from each cut to the first stop message at the motors."""
    delays = []
    for _ in range(count):
        cut_at = time.monotonic()
        ip("link", "set", link.here, "down")
        try:
            first = wait_until(lambda: next((t for x, t in twists(motors) if x == 0.0 and t > cut_at), None), 10,
                               "the stop message after a cut", 0.005)
        finally:
            ip("link", "set", link.here, "up")
        delays.append((first - cut_at) * 1000.0)
        back = time.monotonic()
        wait_until(lambda: sum(1 for x, t in twists(motors) if x == 0.3 and t > back) >= 5, 60,
                   "commands at the motors once the link is back", 0.02)
    return delays


def run(count: int, loss_seconds: float, workdir: Path) -> tuple[list[float], tuple[int, int]]:
    with robot_link() as link, placed(link, workdir) as both:
        cuts(link, both.motors, 2)  # warm-up: the first reconnection
        delays = cuts(link, both.motors, count)
        print(f"  {ros_name()} link cut to stop: p50 {statistics.median(delays):.1f} ms, p99 "
              f"{percentile(delays, 0.99):.1f} ms (lease {LEASE * 1000:.0f} ms)", flush=True)
        with lossy(link):
            start = time.monotonic()
            time.sleep(loss_seconds)
            during = [x for x, t in twists(both.motors) if start < t]
        loss = sum(1 for x in during if x == 0.3), sum(1 for x in during if x == 0.0)
        print(f"  {ros_name()} 10 % loss for {loss_seconds:g} s: {loss[0]} commands, {loss[1]} stop messages",
              flush=True)
        return delays, loss


def figures(delays: list[float], loss: tuple[int, int], seconds: float) -> list[Figure]:
    most = LEASE * 1000 + MARGIN_MS
    ros = ros_name()
    return [Figure(ros, f"machine: link cut to the stop message at the motors, p50 of {len(delays)}",
                   statistics.median(delays), "ms"),
            Figure(ros, f"machine: link cut to the stop message at the motors, p99 of {len(delays)}",
                   percentile(delays, 0.99), "ms", most=most, note=f"lease {LEASE * 1000:.0f} ms + {MARGIN_MS:.0f} ms"),
            Figure(ros, f"machine: false stops in {seconds:g} s at 10 % loss each way, 20 Hz commands",
                   loss[1], "msgs", most=0, note=f"{loss[0]} commands passed")]


def main(argv: Optional[list[str]] = None) -> int:
    stop_cleanly_on_sigterm()
    parser = argparse.ArgumentParser(prog="python -m bench.machine_link", description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="10 cuts, 20 s of loss")
    parser.add_argument("--cuts", type=int, default=None)
    args, _ = parser.parse_known_args(argv)
    if os.geteuid() != 0 or not re.search(r"nft", subprocess.run(["sh", "-c", "command -v nft"], text=True,
                                                                 capture_output=True).stdout):
        print("bench.machine_link: needs root and nftables (network namespaces, a lossy link): skipped")
        return 0
    count = args.cuts or (10 if args.quick else 50)
    seconds = 20.0 if args.quick else 60.0
    began = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="ipyros-bench-machine-") as tmp:
        try:
            delays, loss = run(count, seconds, Path(tmp))
        except BenchError as error:
            print(f"bench: {error}", file=sys.stderr)
            return 1
        except KeyboardInterrupt:
            print("machine bench interrupted", file=sys.stderr)
            return 130
    checks = figures(delays, loss, seconds)
    text = (f"Machine: {machine(ros_name())}; {count} link cuts across a veth pair, lease {LEASE * 1000:.0f} ms; "
            f"{seconds:g} s at 10 % loss.\n\n{table(checks)}\n\n" + "\n".join(target_lines(checks))
            + f"\n\nWhole run: {time.monotonic() - began:.0f} s.\n")
    tag = ros_name().lower().replace(" ", "")
    keep(f"{tag}_machine_link", checks)
    print(text)
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / f"machine_link_{tag}.md").write_text(text)
    return int(any(f.passed is False for f in checks))


if __name__ == "__main__":
    sys.exit(main())
