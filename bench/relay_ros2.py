"""Relay benchmark on ROS 2: what a relay in between costs a topic, four paths side by side.

    python -m bench.relay_ros2            # full run (about 3 minutes on 2 cores)
    python -m bench.relay_ros2 --quick    # one repeat, shorter streams

Run it with the ROS 2 venv (``bash run.sh bench`` does). Publisher, relay and subscriber
are separate rclpy processes (bench/ros2/), in a DDS domain of the bench's own with
discovery kept to this machine, one scenario at a time. Paths:

(a) no relay: publisher → subscriber;
(b) a plain rclpy relay with typed messages, as users write one by hand (topic_tools for
    ROS 2 is a C++ node, not on PyPI), spun by rclpy's single-threaded executor;
(c) an ipyros wrapping node's ``reuse`` relay (serialized bytes, never deserialised);
(d) an ipyros handler that changes one field and ``write``s the message on;
(e) the reuse relay of (c), its publisher standing for a basenode ipyros started: it has the
    session's Fast DDS profile (shared memory of 64 MiB), as such a basenode does; the
    subscriber is a plain rclpy listener with Fast DDS's defaults;
(f) no relay, publisher and subscriber both with ipyros's profile: one shared-memory hop,
    the floor of (e)'s two;
(h) (c)'s node exported as an ament_python package and built by colcon at the bench's start,
    its installed node run without ipyros (bench/exported.py).

Large messages (256 KiB to 16 MiB, a point cloud's size) go through (a), (e) and (f), and a
best-effort 1 MiB stream at 30 Hz (as cameras publish) through (a) and (e). Every other
endpoint is reliable, volatile, 1000 deep (ipyros's default). Measured as in the
ROS 1 bench (bench/relay.py): one-way latency p50/p99 of a paced stream (1 kHz small
messages, 50 Hz 1 MiB images; warm-up cut), messages lost in the first second of a stream
that starts as soon as the publisher matches, flat-out messages/s with loss, and the
relay process's peak memory. Medians over the repeats (start loss: the worst).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import statistics
import sys
import tempfile
import time
from dataclasses import dataclass
from importlib.metadata import version
from pathlib import Path
from typing import Optional

from bench.figures import Figure, keep, machine, target_lines
from bench.relay import BenchError, Child, memory_mib, stop_cleanly_on_sigterm, wait_until

HERE = Path(__file__).resolve().parent
NODES = HERE / "ros2"
RESULTS = HERE / "results"
ROS = "ROS 2"
TOPIC_IN, TOPIC_OUT = "/bench/in", "/bench/out"


@dataclass(frozen=True)
class Load:
    key: str  # what the results are filed under
    kind: str  # the message (bench/ros2/wire2.py's KINDS)
    label: str
    rate_hz: float
    paced: int
    flat: int
    paths: str = "abcdef"  # the paths it runs through
    reliability: str = "reliable"


@dataclass(frozen=True)
class Path_:
    key: str
    label: str
    argv: Optional[list[str]]  # the relay process, {kind} to fill; None: no relay
    #: the publisher stands for a basenode ipyros started, so it has the session's Fast DDS profile
    started_by_ipyros: bool = False
    #: the subscriber has ipyros's profile too (the floor of one shared-memory hop)
    listener_profiled: bool = False
    #: the relay says ``ready TOPIC`` (TOPIC: where to publish); else the bench publishes on TOPIC_IN
    says_ready: bool = True


_REUSE = [sys.executable, str(NODES / "ipyros_node.py"), "reuse", TOPIC_IN, TOPIC_OUT, "{kind}"]

PATHS = [
    Path_("a", "no relay", None),
    Path_("b", "plain rclpy relay, typed", [sys.executable, str(NODES / "typed_relay.py"), TOPIC_IN, TOPIC_OUT, "{kind}"]),
    Path_("c", "ipyros wrapping node, reuse", _REUSE),
    Path_("d", "ipyros node, handler",
          [sys.executable, str(NODES / "ipyros_node.py"), "handler", TOPIC_IN, TOPIC_OUT, "{kind}"]),
    Path_("e", "ipyros wrapping node, reuse, basenode it started", _REUSE, started_by_ipyros=True),
    Path_("f", "no relay, both ends with ipyros's profile", None, started_by_ipyros=True, listener_profiled=True),
    Path_("g", "ipyros wrapping node, reuse, guarded",
          [sys.executable, str(NODES / "ipyros_node.py"), "guarded", TOPIC_IN, TOPIC_OUT, "{kind}"]),
]


@dataclass
class Run:
    p50: Optional[float]  # None: nothing of the paced stream arrived ("0 delivered": a figure too)
    p99: Optional[float]
    start_lost: int
    window: int
    paced_lost: int
    flat_per_s: float
    flat_lost: int
    flat: int
    relay_peak_mib: Optional[float]
    handled: bool


def environment() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("ROS_")}
    env.update(ROS_DOMAIN_ID=str(101 + os.getpid() % 100), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
               AMENT_PREFIX_PATH=os.environ.get("AMENT_PREFIX_PATH", sys.prefix), PYTHONDONTWRITEBYTECODE="1",
               PYTHONPATH=os.pathsep.join(p for p in (str(NODES), os.environ.get("PYTHONPATH")) if p))
    return env


def ipyros_env(env: dict[str, str], workdir: Path) -> dict[str, str]:
    """``env`` as a process started by an ipyros session gets it: with the session's Fast DDS profile
    (a session with discovery kept to this machine writes the loopback one)."""
    from ipyros.ros2 import fastdds

    variables = fastdds.environment(loopback_only=True, folder=workdir / "ipyros")
    if not variables:
        raise BenchError(f"could not write ipyros's Fast DDS profile under {workdir}")
    return {**env, **variables}


def run_once(path: Path_, load: Load, env: dict[str, str], logdir: Path) -> Run:
    procs: list[Child] = []

    def start(name: str, argv: list[str], env: dict[str, str] = env) -> Child:
        procs.append(Child(name, argv, env, logdir))
        return procs[-1]

    try:
        sub = start("sub", [sys.executable, str(NODES / "sub.py"), TOPIC_OUT, load.kind, load.reliability],
                    ipyros_env(env, logdir) if path.listener_profiled else env)
        sub.expect("ready", 30)
        relay = None
        source = TOPIC_OUT
        if path.argv is not None:
            relay = start("relay", [a.replace("{kind}", load.kind) for a in path.argv])
            source = relay.expect("ready", 60) if path.says_ready else TOPIC_IN
            # the relay's output matched downstream before the stream starts, as on ROS 1
            wait_until(lambda: int(sub.ask("publishers")) >= 1, 30, "the subscriber to match the relay", 0.05)
        pub = start("pub", [sys.executable, str(NODES / "pub.py"), source, load.kind, load.reliability],
                    ipyros_env(env, logdir) if path.started_by_ipyros else env)
        pub.expect("ready", 30)
        pub.send(f"go {load.rate_hz} {load.paced} {load.flat}")
        pub.expect("paced", load.paced / load.rate_hz + 60)
        pub.expect("flat", 300)
        expected = load.paced + load.flat
        last, since = -1, time.monotonic()
        while True:  # until everything arrived or nothing more arrives for 2 s
            count = int(sub.ask("count"))
            if count >= expected or (count == last and time.monotonic() - since > 2.0):
                break
            if count != last:
                last, since = count, time.monotonic()
            time.sleep(0.05)
        window = min(load.paced, int(load.rate_hz))
        record = json.loads(sub.ask(f"report {load.paced} {load.paced // 10} {window}", 60))
        latency = sorted(record["latency_ms"])
        if not latency:  # what Fast DDS's defaults do to a best-effort 1 MiB stream: the figure this path shows
            print(f"bench: {path.label}: no paced message arrived ({sub.tail()})", file=sys.stderr, flush=True)
        return Run(p50=statistics.median(latency) if latency else None,
                   p99=latency[min(len(latency) - 1, int(len(latency) * 0.99))] if latency else None,
                   start_lost=record["start_lost"], window=window, paced_lost=load.paced - record["paced_received"],
                   flat_per_s=record["flat_per_s"], flat_lost=load.flat - record["flat_received"], flat=load.flat,
                   relay_peak_mib=memory_mib(relay.proc.pid, "VmHWM") if relay else None, handled=record["handled"])
    finally:
        for proc in reversed(procs):
            proc.stop()


def median_run(runs: list[Run]) -> Run:
    med = lambda values: statistics.median(values)  # noqa: E731
    peaks = [r.relay_peak_mib for r in runs if r.relay_peak_mib is not None]
    delivered = [r for r in runs if r.p50 is not None]  # the latency of the runs that delivered any
    return Run(p50=med([r.p50 for r in delivered]) if delivered else None,
               p99=med([r.p99 for r in delivered]) if delivered else None,
               start_lost=max(r.start_lost for r in runs), window=runs[0].window,
               paced_lost=max(r.paced_lost for r in runs), flat_per_s=med([r.flat_per_s for r in runs]),
               flat_lost=int(med([r.flat_lost for r in runs])), flat=runs[0].flat,
               relay_peak_mib=max(peaks) if peaks else None, handled=all(r.handled for r in runs))


def exported_path(built: Path) -> Path_:
    """Path (h): (c)'s node exported as an ament_python package and built by colcon (bench/exported.py)."""
    from bench import exported

    return Path_("h", "ipyros node exported as a package (rclpy, colcon)",
                 [*exported.command("ros2", built, "{kind}"), *exported.remap("ros2", "{kind}", TOPIC_IN, TOPIC_OUT)],
                 says_ready=False)


def table(results: dict[tuple[str, str], Run], loads: list[Load], repeats: int, paths: list[Path_]) -> str:
    import rclpy

    ros = f"rclpy {version('rclpy')} ({rclpy.get_rmw_implementation_identifier()})"
    lines = [f"Machine: {machine(ros)}; medians of {repeats} run(s), start loss the worst.", "",
             "| message | path | p50 ms | p99 ms | lost at start | paced lost | flat-out msg/s | flat-out lost "
             "| relay peak MiB | handled |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---|"]
    for load in loads:
        for path in paths:
            r = results.get((load.key, path.key))
            if r is None:
                continue
            peak = "-" if r.relay_peak_mib is None else f"{r.relay_peak_mib:.0f}"
            handled = ("yes" if r.handled else "NO") if path.key == "d" else "-"
            p50, p99 = ("0 delivered", "-") if r.p50 is None else (f"{r.p50:.3f}", f"{r.p99:.3f}")
            lines.append(f"| {load.label} | ({path.key}) {path.label} | {p50} | {p99} | "
                         f"{r.start_lost} / {r.window} | {r.paced_lost} | {r.flat_per_s:,.0f} | "
                         f"{r.flat_lost} / {r.flat} | {peak} | {handled} |")
    return "\n".join(lines)


def targets(results: dict[tuple[str, str], Run], loads: list[Load]) -> list[Figure]:
    """Issue 10's: (c) beats (b) on every figure, loses nothing at start, 1 MiB p50 at most 1.5x direct.
    Issue 26's: a camera wrapped by ipyros (e) under 5 ms p50 for 1 MiB and at most half the direct path
    of Fast DDS's defaults; its best-effort stream loses nothing. (e) against (a) at every size is shown."""
    out = []
    for load in loads:
        a, b, c, e, f = (results.get((load.key, k)) for k in "abcef")
        lost = {key: r.paced_lost + r.start_lost for key, r in zip("abcef", (a, b, c, e, f)) if r is not None}
        # a path that delivered nothing has no latency: its loss is its figure
        a, b, c, e, f = (None if r is None or r.p50 is None else r for r in (a, b, c, e, f))
        if b is not None and c is not None:
            out += [Figure(ROS, f"{load.label} p50, reuse relay (c)", c.p50, "ms", "rclpy relay (b)", b.p50, most=1.0),
                    Figure(ROS, f"{load.label} p99, reuse relay (c)", c.p99, "ms", "rclpy relay (b)", b.p99, most=1.0),
                    Figure(ROS, f"{load.label} flat out, reuse relay (c)", c.flat_per_s, "msg/s", "rclpy relay (b)",
                           b.flat_per_s, least=1.0),
                    Figure(ROS, f"{load.label} flat-out lost, reuse relay (c)", c.flat_lost, "msgs",
                           "rclpy relay (b)", b.flat_lost, most=1.0),
                    Figure(ROS, f"{load.label} lost at start, (c)", c.start_lost, "msgs", most=0)]
        if load.key == "image" and a is not None and c is not None:
            out.append(Figure(ROS, f"{load.label} p50, reuse relay (c)", c.p50, "ms", "direct (a)", a.p50, most=1.5))
        if a is not None and e is not None and load.reliability != "best_effort":
            out.append(Figure(ROS, f"{load.label} p50, wrapped camera (e)", e.p50, "ms", "direct (a)", a.p50,
                              most=0.5 if load.key == "image" else None))
        if load.key == "image" and e is not None:
            floor = f"one shared-memory hop (f) takes {f.p50:.3f} ms, (e) makes two" if f is not None else ""
            out.append(Figure(ROS, f"{load.label} p50, wrapped camera (e)", e.p50, "ms", most=5.0, note=floor))
        h = results.get((load.key, "h"))
        if b is not None and h is not None and h.p50 is not None:  # issue 37: the exported package's relay
            out += [Figure(ROS, f"{load.label} p50, exported package relay (h)", h.p50, "ms", "rclpy relay (b)", b.p50),
                    Figure(ROS, f"{load.label} flat out, exported package relay (h)", h.flat_per_s, "msg/s",
                           "rclpy relay (b)", b.flat_per_s),
                    Figure(ROS, f"{load.label} lost at start, (h)", h.start_lost, "msgs", most=0)]
        g = results.get((load.key, "g"))
        if c is not None and g is not None and g.p50 is not None:  # issue 40: a guard's cost, beside (c)
            out += [Figure(ROS, f"{load.label} p50, guarded relay (g)", g.p50, "ms", "reuse relay (c)", c.p50,
                           most=1.1),  # issue 49
                    Figure(ROS, f"{load.label} flat out, guarded relay (g)", g.flat_per_s, "msg/s", "reuse relay (c)",
                           c.flat_per_s, least=0.9),
                    Figure(ROS, f"{load.label} lost at start, (g)", g.start_lost, "msgs", most=0)]
        if load.reliability == "best_effort" and "e" in lost:
            out.append(Figure(ROS, f"{load.label} lost, wrapped camera (e), start included", lost["e"],
                              "msgs", "direct (a)", lost.get("a"), most=0))
    return out


def main(argv: Optional[list[str]] = None) -> int:
    stop_cleanly_on_sigterm()
    parser = argparse.ArgumentParser(prog="python -m bench.relay_ros2", description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="one repeat, shorter streams")
    parser.add_argument("--repeats", type=int, default=None)
    parser.add_argument("--only", help="comma-separated path keys to run, e.g. c,g (the loads that have them)")
    args, _ = parser.parse_known_args(argv)  # `bash run.sh bench` passes ROS 1's options too
    repeats = args.repeats or (1 if args.quick else 3)
    seconds = 2 if args.quick else 4
    loads = [Load("twist", "twist", "TwistStamped (small)", 1000.0, 1000 * seconds, 5000 if args.quick else 20000,
                  paths="abcgdh"),
             Load("image", "image", "Image 1 MiB", 50.0, 50 * seconds, 100 if args.quick else 200, paths="abcdefh"),
             # what shared memory changes: large messages, direct against a camera ipyros wrapped
             Load("image256k", "image256k", "Image 256 KiB", 50.0, 50 * seconds, 100, paths="aef"),
             Load("image4m", "image4m", "Image 4 MiB", 20.0, 20 * seconds, 40, paths="aef"),
             Load("image16m", "image16m", "Image 16 MiB (a point cloud's size)", 10.0, 10 * seconds, 20, paths="aef"),
             Load("image_be", "image", "Image 1 MiB, best effort, 30 Hz", 30.0, 30 * seconds, 0, paths="ae",
                  reliability="best_effort")]
    if args.only:
        keys = set(args.only.split(","))
        loads = [dataclasses.replace(ld, paths="".join(k for k in ld.paths if k in keys)) for ld in loads]
        loads = [ld for ld in loads if ld.paths]
    env = environment()
    results: dict[tuple[str, str], Run] = {}
    status = 0
    paths = list(PATHS)
    with tempfile.TemporaryDirectory(prefix="ipyros-bench-ros2-") as workdir:
        env.update(ROS_HOME=workdir, ROS_LOG_DIR=str(Path(workdir) / "log"))
        from bench import exported

        exporting = [ld.kind for ld in loads if "h" in ld.paths]
        try:
            if exporting:
                print("relay bench: building path (h), the exported package (colcon build)...", flush=True)
                built = exported.build("ros2", Path(workdir), exporting, TOPIC_OUT)
                env["PYTHONPATH"] = os.pathsep.join([*exported.python_path(built), env["PYTHONPATH"]])
                paths.append(exported_path(built))
        except BenchError as error:
            print(f"bench: {error}", file=sys.stderr, flush=True)
            status = 1
        for load in loads:
            for path in (p for p in paths if p.key in load.paths):
                runs = []
                for _ in range(repeats):
                    try:
                        runs.append(run_once(path, load, env, Path(workdir)))
                    except BenchError as error:
                        print(f"bench: {error}", file=sys.stderr, flush=True)
                        status = 1
                if runs:
                    results[(load.key, path.key)] = r = median_run(runs)
                    p50 = "-" if r.p50 is None else f"{r.p50:.3f} ms"  # a path may deliver nothing: a figure too
                    print(f"  {load.key:9} ({path.key}) p50 {p50}, {r.flat_per_s:,.0f} msg/s, "
                          f"{r.paced_lost} of the stream lost", flush=True)
    text = table(results, loads, repeats, paths)
    checks = targets(results, loads)
    text += "\n\nTargets:\n\n" + "\n".join(target_lines(checks))
    keep("ros2_relay", checks)
    print(text)
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "relay_ros2.md").write_text(text + "\n")
    return status or int(any(f.passed is False for f in checks))


if __name__ == "__main__":
    sys.exit(main())
