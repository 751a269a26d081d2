"""The robot as another machine: a relay placed on the robot beside the same relay in the session.

    python -m bench.machine_relay            # 3 s paced and a flat-out burst a kind, each way, 3 times (~2 min)
    python -m bench.machine_relay --quick    # shorter streams, once

ROS 1, as root (network namespaces: the setup of bench/machine_link.py, a robot's namespace joined to this
one by a veth pair). A wrapping node of the laptop's session wraps the bench's stand-in basenode
(``ipyros_bench/idle``) and relays its output; the bench's publisher publishes on the basenode's internal
name in its place, and the bench's subscriber reads the public name, both on the robot, as a driver and
the robot's own consumer of its topic would (bench/nodes/bench_pub.py, bench_sub.py: the relay bench's).

- **session**: the basenode on the laptop (``baseNode("idle")``), the relay in the session: each message
  crosses the link to the laptop and back.
- **placed**: ``.machine("linkbot")``: the keeper on the robot runs the basenode and the relay beside it
  (ipyros/node/placedrelay.py): nothing crosses the link.

Figures per kind (TwistStamped, 1 MiB Image): one-way latency p50/p99 of a paced stream (the publisher's
wall clock in the message, the subscriber's at arrival: one machine, one clock) and flat-out messages/s,
the placed relay's beside the session's as its anchor, over several runs each (five for small messages,
three for images; latency: the messages of all of them; flat out: their median), the two routes taking
turns, each process pinned alike (ipyros's on one core, the bench's on the other). The link
is shaped to 100 Mbit/s each way (tc's token bucket; this kernel has no netem, so no fixed delay is added:
a small message crosses it at once, a camera's images queue as on Wi-Fi). Target (issue 48): the placed relay does not lose
(p50 and p99 at most the session's, flat out at least the session's).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
import xmlrpc.client
from pathlib import Path
from typing import Optional

from bench.figures import Figure, keep, machine, table, target_lines
from bench.machine_link import Link, Placed, placed, robot_link, ros_name
from bench.relay import (NODES, BenchError, Child, Load, Phases, Run, percentile, stop_cleanly_on_sigterm,
                         summarize, wait_drained, wait_until)

RESULTS = Path(__file__).resolve().parent / "results"

def topic_out(kind: str) -> str:
    """The public name, a kind's own (the master keeps a topic's type once it was used)."""
    return f"/bench/out_{kind}"
ROUTES = {"session": "relay in the session (the basenode on the laptop)",
          "placed": "relay placed on the robot (.machine: beside the basenode)"}


def loads(seconds: float, flat_twist: int, flat_image: int) -> list[Load]:
    return [Load("twist", "TwistStamped (small)", 1000.0, int(1000 * seconds), flat_twist),
            Load("image", "Image 1 MiB", 50.0, int(50 * seconds), flat_image)]


def _state(master: str) -> tuple[dict[str, list[str]], dict[str, list[str]]]:
    _, _, (pubs, subs, _) = xmlrpc.client.ServerProxy(master).getSystemState("/bench")
    return dict(pubs), dict(subs)


def _connected(master: str, relay: str, topic: str) -> bool:
    """Whether node ``relay``'s publisher of ``topic`` has a subscriber connected."""
    uri = xmlrpc.client.ServerProxy(master).lookupNode("/bench", relay)[2]
    return any(row[2] == "o" and row[4] == topic for row in xmlrpc.client.ServerProxy(uri).getBusInfo("/b")[2])


#: The link's rate each way: Wi-Fi's order in practice (tc's token bucket: this kernel has no netem).
RATE = "100mbit"


def shape(link: Link, rate: str) -> None:
    """The link shaped to ``rate`` each way (the veth alone is as fast as memory: a relay's crossing would cost
    nothing, and the comparison would say nothing of a robot on Wi-Fi). Gone with the link."""
    for prefix, dev in (((), link.here), (("-n", link.ns), link.there)):
        subprocess.run(["tc", *prefix, "qdisc", "add", "dev", dev, "root", "tbf", "rate", rate, "burst", "256kb",
                        "latency", "500ms"], check=True, capture_output=True, timeout=30)


def _pin(pid: int, cpu: int) -> None:
    """Every thread of process ``pid`` onto ``cpu`` (2 cores: ipyros's processes on one, whichever route and
    machine: the relay's, the keeper, the sessions; the bench's publisher, subscriber and motors on the other.
    Left to the scheduler, where each lands differs run to run by more than the routes differ; and an unpinned
    keeper waking beside the pinned relay host, or beside the subscriber, made a tail of its own)."""
    if (os.cpu_count() or 1) < 2:
        return
    for task in Path(f"/proc/{pid}/task").iterdir():
        try:
            os.sched_setaffinity(int(task.name), {cpu})
        except OSError:  # a thread that just ended
            continue


def _relay_pid(both: Placed, route: str, wrap: Child) -> int:
    """The process the relay runs in: the session's own, or the relay host the keeper started for it."""
    if route == "session":
        return wrap.proc.pid
    said = [line for line in both.keeper.lines if "their process runs (pid " in line]
    if not said:
        raise BenchError("the keeper did not say where the relays run")
    return int(said[-1].split("(pid ")[1].split(")")[0])


def run_once(both: Placed, route: str, load: Load, workdir: Path) -> Run:
    report = workdir / "record.json"
    in_ns = ["ip", "netns", "exec", both.link.ns]
    master = both.on_robot["ROS_MASTER_URI"]
    procs: list[Child] = []
    seen = Phases()
    out = topic_out(load.kind)

    def start(name: str, argv: list[str], env: dict[str, str]) -> Child:
        procs.append(Child(name, argv, {**env, "PYTHONDONTWRITEBYTECODE": "1"}, workdir))
        return procs[-1]

    try:
        sub = start("sub", [*in_ns, sys.executable, str(NODES / "bench_sub.py"), out, load.kind, str(report)],
                    both.on_robot)
        mode = ["placed", "/bench/in", out, load.kind, "linkbot"] if route == "placed" else \
            ["reuse", "/bench/in", out, load.kind]
        relay = start("wrap", [sys.executable, str(NODES / "ipyros_node.py"), *mode], both.on_laptop)
        source = relay.expect("ready", 90)
        sub.expect("ready", 30)
        wait_until(lambda: _state(master)[1].get(out), 30, "the subscriber to register")
        names = wait_until(lambda: _state(master)[1].get(source), 30, f"the relay to subscribe to {source}")
        wait_until(lambda: _connected(master, names[0], out), 30, "the subscriber to connect to the relay")
        pub = start("pub", [*in_ns, sys.executable, str(NODES / "bench_pub.py"), source, load.kind,
                            str(load.rate_hz), str(load.rate_count), str(load.flat_count)], both.on_robot)
        for pid in (_relay_pid(both, route, relay), relay.proc.pid, both.keeper.proc.pid, both.session.proc.pid):
            _pin(pid, 1)  # ipyros's processes, on either machine, on one core
        for pid in (sub.proc.pid, pub.proc.pid, both.motors.proc.pid):
            _pin(pid, 0)  # the bench's own, standing for the robot's other nodes, on the other
        pub.expect("rate-done", load.rate_count / load.rate_hz * 3 + 60)
        seen.rate_received = wait_drained(sub, load.rate_count, quiet=1.0, timeout=30)
        pub.send("go")
        seen.flat_start_ns = int(pub.expect("flat-done", 300).split()[1])
        wait_drained(sub, load.rate_count + load.flat_count, quiet=1.5, timeout=120)
        sub.ask("report", 60)
        record = json.loads(report.read_text())
    finally:
        for proc in reversed(procs):
            proc.stop()
    return summarize(record, load, seen)


def run(load_list: list[Load], workdir: Path, repeats: int) -> dict[tuple[str, str], list[Run]]:
    """Each (kind, route) ``repeats`` times, the routes taking turns (what the machine does meanwhile falls on
    both alike)."""
    runs: dict[tuple[str, str], list[Run]] = {}
    with robot_link() as link, placed(link, workdir, allow=("ipyros_bench",)) as both:
        shape(link, RATE)
        for load in load_list:
            for _ in range(repeats + 2 if load.kind == "twist" and repeats > 1 else repeats):  # a small message's
                # figures are tens of µs: more runs
                for route in ROUTES:
                    found = run_once(both, route, load, workdir)
                    runs.setdefault((load.kind, route), []).append(found)
                    print(f"  {load.label}, {route}: p50 {statistics.median(found.latency_ms):.3f} ms, p99 "
                          f"{percentile(found.latency_ms, 0.99):.3f} ms, flat out {found.flat_per_s:.0f} msg/s "
                          f"({found.flat_received}/{found.flat_sent})", flush=True)
    return runs


def figures(runs: dict[tuple[str, str], list[Run]], load_list: list[Load]) -> list[Figure]:
    """Per kind, the placed relay's medians over its runs beside the session's."""
    found = []
    anchor = "the same relay in the session"
    for load in load_list:
        here, there = runs[(load.kind, "session")], runs[(load.kind, "placed")]
        n = len(there)
        pooled_there = [ms for r in there for ms in r.latency_ms]
        pooled_here = [ms for r in here for ms in r.latency_ms]
        for label, q in (("p50", 0.5), ("p99", 0.99)):
            found.append(Figure(
                "ROS 1", f"machine relay: {load.label} one-way latency {label}, placed on the robot ({n} runs)",
                percentile(pooled_there, q), "ms", anchor, percentile(pooled_here, q), most=1.0))
        lost = sum(r.flat_sent - r.flat_received for r in there), sum(r.flat_sent - r.flat_received for r in here)
        found.append(Figure(
            "ROS 1", f"machine relay: {load.label} flat out, placed on the robot (median of {n})",
            statistics.median(r.flat_per_s for r in there), "msg/s", anchor,
            statistics.median(r.flat_per_s for r in here), least=1.0,
            note=f"lost flat out: {lost[0]} placed, {lost[1]} in the session"))
    return found


def main(argv: Optional[list[str]] = None) -> int:
    stop_cleanly_on_sigterm()
    parser = argparse.ArgumentParser(prog="python -m bench.machine_relay", description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="1 s paced streams, smaller bursts")
    parser.add_argument("--kind", choices=("twist", "image"), help="only this kind of message")
    args, _ = parser.parse_known_args(argv)
    if ros_name() != "ROS 1":
        print("bench.machine_relay: ROS 1 only for now (its publisher and subscriber are rospy's): skipped")
        return 0
    if os.geteuid() != 0:
        print("bench.machine_relay: needs root (network namespaces): skipped")
        return 0
    load_list = loads(1.0, 5000, 50) if args.quick else loads(3.0, 20000, 100)
    load_list = [load for load in load_list if args.kind in (None, load.kind)]
    repeats = 1 if args.quick else 3
    began = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="ipyros-bench-mrelay-") as tmp:
        try:
            runs = run(load_list, Path(tmp), repeats)
        except BenchError as error:
            print(f"bench: {error}", file=sys.stderr)
            return 1
        except KeyboardInterrupt:
            print("machine relay bench interrupted", file=sys.stderr)
            return 130
    checks = figures(runs, load_list)
    text = (f"Machine: {machine('ROS 1')}; the robot in a network namespace of its own, across a veth pair; "
            f"publisher and subscriber on the robot, the session on the laptop.\n\n{table(checks)}\n\n"
            + "\n".join(target_lines(checks)) + f"\n\nWhole run: {time.monotonic() - began:.0f} s.\n")
    keep("ros1_machine_relay", checks)
    print(text)
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "machine_relay_ros1.md").write_text(text)
    return int(any(f.passed is False for f in checks))


if __name__ == "__main__":
    sys.exit(main())
