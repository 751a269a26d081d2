"""Relay benchmark: what a relay in between costs a ROS topic, for four kinds of relay.

    python -m bench.relay            # full run (about 4 minutes on 2 cores)
    python -m bench.relay --quick    # smoke run (about 1 minute)
    python -m bench.relay --recipes  # rospy relay variants side by side (how the recipe was found)

Everything runs on loopback against a rosmaster of the bench's own, on a free port;
publisher, relay and subscriber are separate processes (bench/nodes/), started and
stopped by the bench, one scenario at a time (2 cores: three busy processes already
contend). For each message kind and path the bench measures, from one publisher run:

- **one-way latency** p50/p99: the publisher stamps ``header.stamp`` with the wall clock
  just before writing; the subscriber subtracts it from its wall clock on arrival. The
  paced part of the run (1 kHz / 50 Hz) is measured, less its first 10 % (warm-up).
- **messages lost at the start of a stream**: subscriber and relay are up (registered;
  a relay that advertises its output up front is connected to the subscriber); the
  publisher advertises and starts the paced stream as soon as it sees a connection
  (``get_num_connections() > 0``). Lost = how many of the first second's messages never
  arrive downstream.
- **flat-out throughput** with loss: then the publisher writes a fixed count as fast as
  the connection takes them; messages/s is counted at the subscriber (first to last
  arrival), lost = sent - received.
- the relay's **CPU per message** at the paced rate (all its threads, from schedstat).

Paths: (a) no relay, (b) topic_tools' C++ relay, (c) an ipyros wrapping node's reuse relay,
(g) the same guarded, (d) an ipyros handler, (h) (c)'s node exported as C++ and built by
catkin_make at the bench's start (bench/exported.py).

The medians over the repeats are shown (start loss: the worst repeat). The targets of
issue 3 are checked and printed PASS/FAIL; the table is saved to bench/results/relay.md.
"""

from __future__ import annotations

import argparse
import ctypes
import json
import math
import os
import queue
import shutil
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import xmlrpc.client
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Optional

from bench import figures
from bench.errors import BenchError
from bench.figures import Figure, keep, target_lines
from bench.nodes import wire  # message kinds; the node scripts import it as plain `wire`

HERE = Path(__file__).resolve().parent
NODES = HERE / "nodes"
RESULTS = HERE / "results"
ROS = "ROS 1"
TOPIC_IN, TOPIC_OUT = "/bench/in", "/bench/out"
TOPIC_TOOLS_RELAY = Path("/usr/lib/topic_tools/relay")


# -- what is measured ----------------------------------------------------------------------


@dataclass(frozen=True)
class Load:
    """One message kind, paced then flat out."""

    kind: str
    label: str
    rate_hz: float
    rate_count: int
    flat_count: int

    @property
    def start_window(self) -> int:
        """The first second of the stream, where start-of-stream loss is counted."""
        return min(self.rate_count, int(self.rate_hz))

    @property
    def warmup(self) -> int:
        return self.rate_count // 10


@dataclass(frozen=True)
class Route:
    """One way from publisher to subscriber: straight, or through a relay process."""

    key: str
    label: str
    relay: Optional[list[str]] = None  # relay argv, with {kind} to fill; None: no relay
    note: str = ""
    handler: bool = False  # the relay changes a field of every message (path d)
    says_ready: bool = True  # the relay says "ready TOPIC", TOPIC being where to publish
    kinds: tuple[str, ...] = ("twist", "image")  # the messages it is run with

    def argv(self, kind: str) -> Optional[list[str]]:
        return None if self.relay is None else [a.replace("{kind}", kind) for a in self.relay]


def rospy_relay(*options: str) -> list[str]:
    return [sys.executable, str(NODES / "rospy_relay.py"), TOPIC_IN, TOPIC_OUT, "{kind}", *options]


def ipyros_node(mode: str) -> list[str]:
    return [sys.executable, str(NODES / "ipyros_node.py"), mode, TOPIC_IN, TOPIC_OUT, "{kind}"]


def topic_tools_relay() -> Route:
    return Route("b", "topic_tools relay (C++)", [str(TOPIC_TOOLS_RELAY), TOPIC_IN, TOPIC_OUT], says_ready=False)


def exported_route(built: Path) -> Route:
    """Path (h): (c)'s node exported as C++ and built by catkin_make (bench/exported.py)."""
    from bench import exported

    return Route("h", "ipyros node exported as C++ (roscpp)",
                 [*exported.command("ros1", built, "{kind}"), *exported.remap("ros1", "{kind}", TOPIC_IN, TOPIC_OUT)],
                 "(c)'s node written by nd.export(DIR, language=\"cpp\") and built by catkin_make: a ShapeShifter "
                 "byte relay, run without ipyros (bench/exported.py)", says_ready=False)


def main_routes(rospy_only: bool = False) -> list[Route]:
    """Issue 3's four paths; ``rospy_only`` runs (c) and (d) as bench/nodes/rospy_relay.py's recipe."""
    if rospy_only:
        reuse = Route("c", "rospy reuse relay (recipe)", rospy_relay(), "bench/nodes/rospy_relay.py")
        handler = Route("d", "rospy handler (recipe)", rospy_relay("--mode", "handler"),
                        "bench/nodes/rospy_relay.py --mode handler", handler=True)
    else:
        reuse = Route("c", "ipyros wrapping node, reuse", ipyros_node("reuse"),
                      "a wrapping node's reuse.publish relay (bench/nodes/ipyros_node.py)")
        handler = Route("d", "ipyros node, handler", ipyros_node("handler"),
                        "new.subscribe(handler) + write() (bench/nodes/ipyros_node.py)", handler=True)
        guarded = Route("g", "ipyros wrapping node, reuse, guarded", ipyros_node("guarded"),
                        "(c) with a guard on its output: limits on two fields, NaN and infinities checked "
                        "(issue 40)", kinds=("twist",))
        return [Route("a", "no relay", says_ready=False), topic_tools_relay(), reuse, guarded, handler]
    return [Route("a", "no relay", says_ready=False), topic_tools_relay(), reuse, handler]


def recipe_routes() -> list[Route]:
    """The rospy relay variants compared to find the recipe: R4 (reuse) and R12 (handler) won."""
    naive = ("--sub-queue", "10", "--pub-queue", "10", "--buff-size", "65536", "--sub-nodelay", "0")
    return [
        Route("a", "no relay", says_ready=False),
        topic_tools_relay(),
        Route("R1", "typed, queues 10/10, publish()", rospy_relay("--mode", "handler", "--typed-write", "publish",
                                                                   *naive), handler=True),
        Route("R2", "AnyMsg, queues 10/10, impl.publish", rospy_relay("--write", "impl", *naive)),
        Route("R3", "AnyMsg, sub unbounded, pub queue 10", rospy_relay("--write", "impl", "--pub-queue", "10")),
        Route("R4", "AnyMsg, unbounded, sync, sendmsg, 127 KiB reads, nodelay", rospy_relay()),
        Route("R4b", "R4 again (how noisy the machine is)", rospy_relay()),
        Route("R5", "R4, buff_size 64 KiB (rospy default)", rospy_relay("--buff-size", "65536")),
        Route("R6", "R4, buff_size 4 MiB", rospy_relay("--buff-size", str(4 << 20))),
        Route("R7", "R4, no tcp_nodelay request", rospy_relay("--sub-nodelay", "0")),
        Route("R8", "R4, impl.publish(raw)", rospy_relay("--write", "impl")),
        Route("R9", "R4, length+bytes joined, write_data", rospy_relay("--write", "joined")),
        Route("R10", "R4, advertised on 1st message", rospy_relay("--advertise", "lazy")),
        Route("R11", "R4, glibc mallopt", rospy_relay("--mallopt")),
        Route("R12", "typed, unbounded, sync, publish()", rospy_relay("--mode", "handler"), handler=True),
        Route("R13", "R12, kept buffer + sendmsg", rospy_relay("--mode", "handler", "--typed-write", "buffer"),
              handler=True),
        Route("R14", "R12, glibc mallopt", rospy_relay("--mode", "handler", "--mallopt"), handler=True),
        *main_routes()[2:],  # ipyros as it is now, for comparison
    ]


def loads(seconds: float, flat_twist: int, flat_image: int) -> list[Load]:
    return [
        Load("twist", "TwistStamped (small)", 1000.0, int(1000 * seconds), flat_twist),
        Load("image", "Image 1 MiB", 50.0, int(50 * seconds), flat_image),
    ]


@dataclass
class Run:
    """What one publisher run through one route showed."""

    latency_ms: list[float]
    start_lost: int
    rate_sent: int
    rate_received: int
    flat_sent: int
    flat_received: int
    flat_per_s: float
    relay_cpu_us: Optional[float]  # relay CPU per message, paced (wake-ups included)
    relay_flat_cpu_us: Optional[float]  # relay CPU per message, flat out (per-message work)
    header_ok: bool
    handled: int
    foreign_cores: float  # other processes' CPU during the run, in cores


# -- processes -----------------------------------------------------------------------------

_libc = ctypes.CDLL(None, use_errno=True)
_PR_SET_PDEATHSIG = 1


def _die_with_parent() -> None:
    """In the child, before exec: be sent SIGTERM if the bench dies, so nothing is left behind."""
    _libc.prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)


class Child:
    """A bench process: lines in on stdin, lines out on stdout, stderr to a log file."""

    def __init__(self, name: str, argv: list[str], env: dict[str, str], logdir: Path) -> None:
        self.name = name
        self.log = logdir / f"{name}.log"
        with open(self.log, "w") as err:
            self.proc = subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=err,
                                         text=True, env=env, preexec_fn=_die_with_parent)
        self.lines: queue.Queue[Optional[str]] = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            self.lines.put(line.strip())
        self.lines.put(None)

    def send(self, line: str) -> None:
        try:
            self.proc.stdin.write(line + "\n")
            self.proc.stdin.flush()
        except (BrokenPipeError, OSError):
            pass  # it exited: expect() says so

    def expect(self, word: str, timeout: float) -> str:
        """The next line that starts with ``word``; fails on an error line, exit or timeout."""
        deadline = time.monotonic() + timeout
        while True:
            try:
                line = self.lines.get(timeout=max(0.0, deadline - time.monotonic()))
            except queue.Empty:
                raise BenchError(f"{self.name}: no '{word}' within {timeout:.0f}s; see {self.tail()}") from None
            if line is None or line.startswith("error"):
                raise BenchError(f"{self.name}: {line or 'exited'} while waiting for '{word}'; see {self.tail()}")
            if line.startswith(word):
                return line[len(word):].strip()

    def ask(self, command: str, timeout: float = 10.0) -> str:
        self.send(command)
        return self.expect("", timeout)

    def cpu_ns(self) -> int:
        return process_cpu_ns(self.proc.pid)

    def tail(self, lines: int = 5) -> str:
        try:
            text = self.log.read_text().strip().splitlines()[-lines:]
        except OSError:
            text = []
        return " | ".join(text) or f"(empty log {self.log})"

    def stop(self) -> None:
        """Ask it to quit (stdin closed, then SIGINT, SIGTERM, SIGKILL), and reap it."""
        if self.proc.poll() is None:
            try:
                self.proc.stdin.close()
            except OSError:
                pass
            for sig, wait in ((None, 3.0), (signal.SIGINT, 3.0), (signal.SIGTERM, 3.0), (signal.SIGKILL, 10.0)):
                if sig is not None:
                    self.proc.send_signal(sig)
                try:
                    self.proc.wait(wait)
                    break
                except subprocess.TimeoutExpired:
                    continue
        if self.proc.stdout:
            self.proc.stdout.close()


def process_cpu_ns(pid: int) -> int:
    """CPU time of all threads of a process so far (ns), from /proc/PID/task/*/schedstat."""
    total = 0
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            total += int((task / "schedstat").read_text().split()[0])
        except (OSError, ValueError, IndexError):
            pass  # a thread ended between listing and reading
    return total


def machine_busy_ns() -> int:
    """CPU time all CPUs spent busy so far, every process and the hypervisor's steal included."""
    fields = Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:]
    user, nice, system, idle, iowait, irq, softirq, steal = map(int, fields[:8])
    return (user + nice + system + irq + softirq + steal) * 1_000_000_000 // os.sysconf("SC_CLK_TCK")


class ForeignLoad:
    """How busy the machine was with processes other than the bench's, over a window.

    The bench shares its 2 cores with whatever else runs; a run during which others
    took a sizeable share of a core measures them as much as the relay, so it is run
    again (see run_all).
    """

    def __init__(self, pids: list[int]) -> None:
        self.pids = pids
        self.began = time.monotonic()
        self.busy = machine_busy_ns()
        self.ours = self._ours()

    def _ours(self) -> int:
        return sum(process_cpu_ns(pid) for pid in self.pids)

    def cores(self) -> float:
        """Others' average use over the window, in cores (0.5 = half a core)."""
        elapsed = time.monotonic() - self.began
        foreign = (machine_busy_ns() - self.busy) - (self._ours() - self.ours)
        return max(0.0, foreign / 1e9 / elapsed) if elapsed > 0 else 0.0


def stop_cleanly_on_sigterm() -> None:
    """SIGTERM ends a bench as Ctrl-C does: its ``finally`` blocks stop the processes it started and
    remove its temporary folders (by default Python would just die, leaving them behind)."""
    def stop(signum: int, frame: object) -> None:
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, stop)


def memory_mib(pid: int, field: str = "VmRSS") -> Optional[float]:
    """A field of ``/proc/PID/status`` in MiB: resident memory now (``VmRSS``) or at its peak (``VmHWM``);
    None if the process is gone."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith(field + ":"):
                return int(line.split()[1]) / 1024
    except OSError:
        pass
    return None


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_until(predicate: Callable[[], object], timeout: float, what: str, interval: float = 0.01):
    deadline = time.monotonic() + timeout
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() > deadline:
            raise BenchError(f"timed out after {timeout:.0f}s waiting for {what}")
        time.sleep(interval)


class Master:
    """A rosmaster of the bench's own, and the environment its nodes get."""

    def __init__(self, workdir: Path) -> None:
        self.uri = f"http://127.0.0.1:{free_port()}/"
        self.env = {k: v for k, v in os.environ.items() if not k.startswith("ROS_")}
        self.env.update(ROS_MASTER_URI=self.uri, ROS_IP="127.0.0.1", ROS_HOME=str(workdir),
                        ROS_LOG_DIR=str(workdir / "log"), PYTHONDONTWRITEBYTECODE="1")
        self.logdir = workdir
        port = self.uri.rsplit(":", 1)[1].strip("/")
        self.child = Child("rosmaster", ["rosmaster", "--core", "-p", port, "-w", "3"], self.env, workdir)
        self.proxy = xmlrpc.client.ServerProxy(self.uri)
        wait_until(self._answers, 20, "rosmaster to answer", 0.05)

    def _answers(self) -> bool:
        try:
            return self.proxy.getPid("/bench")[0] == 1
        except OSError:
            return False

    def state(self) -> tuple[dict[str, list[str]], dict[str, list[str]]]:
        """(publishers by topic, subscribers by topic)."""
        _, _, (pubs, subs, _) = self.proxy.getSystemState("/bench")
        return dict(pubs), dict(subs)

    def node_uri(self, name: str) -> str:
        return self.proxy.lookupNode("/bench", name)[2]

    def stop(self) -> None:
        self.child.stop()


# -- one scenario --------------------------------------------------------------------------


def wait_drained(sub: Child, expected: int, quiet: float, timeout: float) -> int:
    """Poll the subscriber's count until it reaches ``expected`` or stops growing for ``quiet`` s."""
    deadline = time.monotonic() + timeout
    last, since = -1, time.monotonic()
    while True:
        count = int(sub.ask("count"))
        now = time.monotonic()
        if count >= expected:
            return count
        if count != last:
            last, since = count, now
        elif now - since > quiet or now > deadline:
            return count
        time.sleep(0.05)


def relay_connected(master: Master, relay_name: str) -> bool:
    """Whether the relay's publisher on the output topic has a connection (node bus info)."""
    info = xmlrpc.client.ServerProxy(master.node_uri(relay_name)).getBusInfo("/bench")[2]
    return any(row[2] == "o" and row[4] == TOPIC_OUT for row in info)


def wait_ready(master: Master, sub: Child, relay: Optional[Child], source: str) -> None:
    """Subscriber (and relay) registered; a relay publishing already is connected downstream."""
    sub.expect("ready", 30)
    wait_until(lambda: master.state()[1].get(TOPIC_OUT), 30, "the subscriber to register")
    if relay is None:
        return
    names = wait_until(lambda: master.state()[1].get(source), 30, f"the relay to subscribe to {source}")
    if TOPIC_OUT in master.state()[0]:  # advertised up front: let the subscriber connect first
        wait_until(lambda: relay_connected(master, names[0]), 30, "the subscriber to connect to the relay")


@dataclass
class Phases:
    """What the bench saw while one run went on, besides the subscriber's record."""

    rate_received: int = 0
    flat_start_ns: int = 0  # wall clock of the first flat-out write
    relay_rate_ns: Optional[int] = None  # relay CPU during the paced stream
    relay_flat_ns: Optional[int] = None  # relay CPU during the flat-out burst
    foreign_cores: float = 0.0


def run_once(master: Master, route: Route, load: Load, workdir: Path) -> Run:
    report = workdir / "record.json"
    procs: list[Child] = []
    seen = Phases()

    def start(name: str, argv: list[str]) -> Child:
        procs.append(Child(name, argv, master.env, master.logdir))
        return procs[-1]

    def relay_cpu() -> int:
        return relay.cpu_ns() if relay else 0

    try:
        sub = start("sub", [sys.executable, str(NODES / "bench_sub.py"), TOPIC_OUT, load.kind, str(report)])
        relay_argv = route.argv(load.kind)
        relay = start("relay", relay_argv) if relay_argv else None
        source = TOPIC_OUT if relay is None else relay.expect("ready", 60) if route.says_ready else TOPIC_IN
        wait_ready(master, sub, relay, source)
        pub = start("pub", [sys.executable, str(NODES / "bench_pub.py"), source,
                            load.kind, str(load.rate_hz), str(load.rate_count), str(load.flat_count)])
        others = ForeignLoad([os.getpid(), master.child.proc.pid] + [p.proc.pid for p in procs])
        cpu = relay_cpu()
        pub.expect("rate-done", load.rate_count / load.rate_hz * 3 + 60)
        seen.rate_received = wait_drained(sub, load.rate_count, quiet=1.0, timeout=30)
        cpu, seen.relay_rate_ns = relay_cpu(), relay_cpu() - cpu
        pub.send("go")
        seen.flat_start_ns = int(pub.expect("flat-done", 300).split()[1])
        wait_drained(sub, load.rate_count + load.flat_count, quiet=1.5, timeout=120)
        seen.relay_flat_ns = relay_cpu() - cpu
        seen.foreign_cores = others.cores()
        sub.ask("report", 60)
        record = json.loads(report.read_text())
    finally:
        for proc in reversed(procs):
            proc.stop()
    if relay is None:
        seen.relay_rate_ns = seen.relay_flat_ns = None
    return summarize(record, load, seen)


def percentile(values: list[float], q: float) -> float:
    """Nearest-rank percentile of an unsorted list (q in 0..1)."""
    ordered = sorted(values)
    return ordered[max(0, math.ceil(q * len(ordered)) - 1)] if ordered else math.nan


def summarize(record: dict, load: Load, seen: Phases) -> Run:
    """One run's figures. Flat-out msg/s: messages received over the time from the
    publisher's first flat-out write to the last arrival, so that a path that drops
    messages is not credited with the rate of the few it lets through."""
    index, latency, received = record["index"], record["latency_ns"], record["received_ns"]
    got = set(index)
    flat = [t for i, t in zip(index, received) if i >= load.rate_count]
    span = (max(flat) - seen.flat_start_ns) / 1e9 if flat else 0.0
    kind = wire.KINDS[load.kind]
    cls = wire.message_class(load.kind)
    header = record["header"]

    def per_message_us(ns: Optional[int], count: int) -> Optional[float]:
        return ns / 1e3 / count if ns is not None and count else None

    # Relay CPU per message *sent*: a relay that drops messages is not credited per survivor.

    return Run(
        latency_ms=[lat / 1e6 for i, lat in zip(index, latency) if load.warmup <= i < load.rate_count],
        start_lost=sum(1 for i in range(load.start_window) if i not in got),
        rate_sent=load.rate_count,
        rate_received=seen.rate_received,
        flat_sent=load.flat_count,
        flat_received=len(flat),
        flat_per_s=len(flat) / span if span > 0 else 0.0,
        relay_cpu_us=per_message_us(seen.relay_rate_ns, load.rate_count),
        relay_flat_cpu_us=per_message_us(seen.relay_flat_ns, load.flat_count),
        header_ok=(header.get("type") == kind.type_name and header.get("md5sum") == cls._md5sum
                   # gencpp's text of a definition may end in one more newline than genpy's (Debian's
                   # geometry_msgs): a relay that advertises with its own C++ type (h) says the same definition
                   and header.get("message_definition", "").rstrip() == cls._full_text.rstrip()),
        handled=record["handled"],
        foreign_cores=seen.foreign_cores,
    )


# -- many scenarios, and what they add up to -----------------------------------------------


@dataclass
class Cell:
    """The repeats of one (load, route), reduced to the figures of the table."""

    load: Load
    route: Route
    runs: list[Run] = field(default_factory=list)
    error: str = ""
    reruns: int = 0  # runs done again because other processes were busy

    def _median(self, get: Callable[[Run], Optional[float]]) -> float:
        values = [v for v in map(get, self.runs) if v is not None and not math.isnan(v)]
        return statistics.median(values) if values else math.nan

    @property
    def p50(self) -> float:
        return self._median(lambda r: percentile(r.latency_ms, 0.50))

    @property
    def p99(self) -> float:
        return self._median(lambda r: percentile(r.latency_ms, 0.99))

    @property
    def per_s(self) -> float:
        return self._median(lambda r: r.flat_per_s)

    @property
    def flat_lost(self) -> float:
        return self._median(lambda r: r.flat_sent - r.flat_received)

    @property
    def start_lost(self) -> int:
        return max((r.start_lost for r in self.runs), default=-1)

    @property
    def cpu_us(self) -> float:
        return self._median(lambda r: r.relay_cpu_us)

    @property
    def flat_cpu_us(self) -> float:
        return self._median(lambda r: r.relay_flat_cpu_us)

    def bytes_check(self) -> str:
        """'ok' when every run's connection header was right and handler changes went where due."""
        if not all(r.header_ok for r in self.runs):
            return "WRONG header"
        received = [r.rate_received + r.flat_received for r in self.runs]
        expected = received if self.route.handler else [0] * len(self.runs)
        return "ok" if [r.handled for r in self.runs] == expected else "WRONG change"


def measure(master: Master, cell: Cell, workdir: Path, quiet_below: float, attempts: int) -> Run:
    """One run of a cell; run again while other processes took ``quiet_below`` cores or more."""
    runs = []
    for _ in range(attempts):
        runs.append(run_once(master, cell.route, cell.load, workdir))
        if runs[-1].foreign_cores < quiet_below:
            break
        cell.reruns += 1
    return min(runs, key=lambda r: r.foreign_cores)


def run_all(routes: list[Route], load_list: list[Load], repeats: int, log: Callable[[str], None],
            quiet_below: float = 0.25, attempts: int = 2) -> list[Cell]:
    cells = [Cell(load, route) for load in load_list for route in routes if load.kind in route.kinds]
    with tempfile.TemporaryDirectory(prefix="ipyros-bench-") as tmp:
        master = Master(Path(tmp))
        try:
            for rep in range(repeats):  # repeats outermost: a slow spell of the machine hits all routes alike
                for cell in cells:
                    if cell.error:
                        continue
                    began = time.monotonic()
                    try:
                        run = measure(master, cell, Path(tmp), quiet_below, attempts)
                    except BenchError as error:
                        cell.error = str(error)
                        log(f"  {cell.load.kind:5} {cell.route.key:3} FAILED: {error}")
                        continue
                    cell.runs.append(run)
                    log(f"  [{rep + 1}/{repeats}] {cell.load.kind:5} {cell.route.key:3} "
                        f"p50 {percentile(run.latency_ms, .5):.3f} ms  p99 {percentile(run.latency_ms, .99):.3f} ms  "
                        f"start lost {run.start_lost}  flat {run.flat_per_s:,.0f}/s lost {run.flat_sent - run.flat_received}"
                        f"  others {run.foreign_cores:.2f} cores  ({time.monotonic() - began:.1f}s)")
        finally:
            master.stop()
    return cells


def check_targets(cells: list[Cell]) -> list[Figure]:
    """Issue 3's and 26's targets, per message kind, as figures beside their anchors: the reuse relay
    (c) against topic_tools (b) and within 1.5x of the direct path (a); the handler (d) within 1.3x
    of the relay; nothing lost at start through ipyros."""
    by = {(c.load.kind, c.route.key): c for c in cells if c.runs}
    out = []
    for kind in dict.fromkeys(c.load.kind for c in cells):
        a, b, c, d = (by.get((kind, key)) for key in "abcd")
        label = (a or b or c or d).load.label if (a or b or c or d) else kind
        if c and b:
            out += [Figure(ROS, f"{label} p50, reuse relay (c)", c.p50, "ms", "topic_tools (b)", b.p50, most=1.0),
                    Figure(ROS, f"{label} p99, reuse relay (c)", c.p99, "ms", "topic_tools (b)", b.p99, most=1.0),
                    Figure(ROS, f"{label} flat out, reuse relay (c)", c.per_s, "msg/s", "topic_tools (b)", b.per_s,
                           least=1.0)]
        if c and a:  # issue 26's target is for 1 MiB; for small messages it is shown
            out.append(Figure(ROS, f"{label} p50, reuse relay (c)", c.p50, "ms", "direct (a)", a.p50,
                              most=1.5 if kind == "image" else None))
        if c and d:
            out += [Figure(ROS, f"{label} p50, handler (d)", d.p50, "ms", "reuse relay (c)", c.p50, most=1.3),
                    Figure(ROS, f"{label} p99, handler (d)", d.p99, "ms", "reuse relay (c)", c.p99, most=1.3),
                    Figure(ROS, f"{label} flat out, handler (d)", d.per_s, "msg/s", "reuse relay (c)", c.per_s,
                           least=1 / 1.3)]
        for cell in (c, d):
            if cell:
                out.append(Figure(ROS, f"{label} lost at start, ({cell.route.key}), worst of {len(cell.runs)}",
                                  cell.start_lost, "msgs", most=0))
        h = by.get((kind, "h"))
        if h and b:  # issue 37: the exported C++ relay beside topic_tools' and ipyros's own
            out += [Figure(ROS, f"{label} p50, exported C++ relay (h)", h.p50, "ms", "topic_tools (b)", b.p50),
                    Figure(ROS, f"{label} flat out, exported C++ relay (h)", h.per_s, "msg/s", "topic_tools (b)",
                           b.per_s)]
        if h and c:
            out += [Figure(ROS, f"{label} p50, exported C++ relay (h)", h.p50, "ms", "reuse relay (c)", c.p50),
                    Figure(ROS, f"{label} relay CPU µs/msg flat out, exported C++ relay (h)", h.flat_cpu_us, "µs",
                           "reuse relay (c)", c.flat_cpu_us)]
        g = by.get((kind, "g"))
        if c and g:  # issue 40: what a guard costs a relay, beside the same relay unguarded
            out += [Figure(ROS, f"{label} p50, guarded relay (g)", g.p50, "ms", "reuse relay (c)", c.p50, most=1.1),
                    Figure(ROS, f"{label} flat out, guarded relay (g)", g.per_s, "msg/s", "reuse relay (c)", c.per_s,
                           least=0.9),  # issue 49
                    Figure(ROS, f"{label} relay CPU µs/msg flat out, guarded relay (g)", g.flat_cpu_us, "µs",
                           "reuse relay (c)", c.flat_cpu_us),
                    Figure(ROS, f"{label} CPU the guard adds to a relay, per message", g.flat_cpu_us - c.flat_cpu_us,
                           "µs", most=15.0),
                    Figure(ROS, f"{label} flat out, guarded relay (g), issue 40's floor", g.per_s, "msg/s",
                           least=10000.0),
                    Figure(ROS, f"{label} lost at start, (g), worst of {len(g.runs)}", g.start_lost, "msgs", most=0)]
    return out


def machine() -> str:
    """The machine (:func:`bench.figures.machine`) with Debian's ros_comm version."""
    try:
        ros = subprocess.run(["dpkg-query", "-W", "-f", "${Version}", "python3-rospy"],
                             capture_output=True, text=True, timeout=10).stdout.strip() or "unknown"
    except (OSError, subprocess.SubprocessError):
        ros = "unknown"
    return figures.machine(f"ros_comm {ros} (Debian)")


def _ms(value: float) -> str:
    return "-" if math.isnan(value) else f"{value:.3f}"


def table(cells: list[Cell], routes: list[Route], load_list: list[Load], repeats: int) -> str:
    lines = [
        f"Machine: {machine()}",
        f"Repeats: {repeats} (medians; start loss: worst repeat). "
        + "; ".join(f"{ld.label}: {ld.rate_count} at {ld.rate_hz:g} Hz, then {ld.flat_count} flat out"
                    for ld in load_list),
        "",
        "| message | path | p50 ms | p99 ms | lost at start | flat-out msg/s | flat-out lost "
        "| relay CPU µs/msg paced / flat | bytes |",
        "|---|---|---:|---:|---:|---:|---:|---:|---|",
    ]
    for cell in cells:
        ld = cell.load
        name = f"({cell.route.key}) {cell.route.label}"
        if cell.error or not cell.runs:
            why = (cell.error or "no run").split(";")[0]  # the whole message is in the log above
            lines.append(f"| {ld.label} | {name} | failed: {why} ||||||| ")
            continue
        cpu = "-" if math.isnan(cell.cpu_us) else f"{cell.cpu_us:.0f} / {cell.flat_cpu_us:.1f}"
        lines.append(f"| {ld.label} | {name} | {_ms(cell.p50)} | {_ms(cell.p99)} | "
                     f"{cell.start_lost} / {ld.start_window} | {cell.per_s:,.0f} | "
                     f"{cell.flat_lost:g} / {ld.flat_count} | {cpu} | {cell.bytes_check()} |")
    foreign = [r.foreign_cores for c in cells for r in c.runs]
    lines += ["", "bytes: downstream saw the publisher's type, md5 and message definition, and the handler's "
              "change on every message through a handler and on none through a relay.",
              f"Other processes on the machine used {statistics.median(foreign or [0]):.2f} cores (median, "
              f"max {max(foreign or [0]):.2f}) during the runs kept; runs done again because others used "
              f"0.25 cores or more: {sum(c.reruns for c in cells)}."]
    notes = [f"({r.key}) {r.note}" for r in routes if r.note]
    if notes:
        lines += ["Relays: " + "; ".join(notes) + "."]
    return "\n".join(lines)


def parse(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="python -m bench.relay", description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smoke run: 1 repeat, shorter streams (~1 minute)")
    parser.add_argument("--recipes", action="store_true", help="compare rospy relay variants instead")
    parser.add_argument("--repeats", type=int, help="runs per scenario (default 3, quick 1)")
    parser.add_argument("--seconds", type=float, help="length of the paced stream (default 3, quick 1.5)")
    parser.add_argument("--flat-twist", type=int, help="small messages sent flat out (default 200000, quick 60000)")
    parser.add_argument("--flat-image", type=int, help="images sent flat out (default 200, quick 60)")
    parser.add_argument("--rospy-only", action="store_true",
                        help="run (c) and (d) with bench/nodes/rospy_relay.py's recipe instead of ipyros")
    parser.add_argument("--attempts", type=int, default=2,
                        help="runs of a scenario at most, while other processes use 0.25 cores or more (default 2)")
    parser.add_argument("--only", help="comma-separated route keys to run, e.g. a,b,R4")
    parser.add_argument("--kinds", default="twist,image", help="message kinds to run (twist,image)")
    parser.add_argument("--out", type=Path, help="where to save the table (default bench/results/relay.md)")
    return parser.parse_args(argv)


def main(argv=None) -> int:
    stop_cleanly_on_sigterm()
    opts = parse(argv)
    quick = opts.quick
    repeats = opts.repeats or (1 if quick else 3)
    load_list = [ld for ld in loads(opts.seconds or (1.5 if quick else 3.0),
                                    opts.flat_twist or (60000 if quick else 200000),
                                    opts.flat_image or (60 if quick else 200))
                 if ld.kind in opts.kinds.split(",")]
    routes = recipe_routes() if opts.recipes else main_routes(opts.rospy_only)
    if opts.only:
        routes = [r for r in routes if r.key in opts.only.split(",")]
    if not TOPIC_TOOLS_RELAY.exists():
        print(f"note: {TOPIC_TOOLS_RELAY} is missing (apt install topic-tools); skipping path (b)")
        routes = [r for r in routes if r.key != "b"]
    if shutil.which("rosmaster") is None:
        print("rosmaster is not on PATH: install python3-rosmaster (bash run.sh does)", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory(prefix="ipyros-bench-exported-") as built_in:
        return _run(opts, routes, load_list, repeats, Path(built_in))


def _run(opts: argparse.Namespace, routes: list[Route], load_list: list[Load], repeats: int, workdir: Path) -> int:
    if not opts.recipes and not opts.rospy_only and (not opts.only or "h" in opts.only.split(",")):
        from bench import exported

        if shutil.which("catkin_make") is None:
            print("note: catkin_make is missing (apt install catkin libroscpp-dev libtopic-tools-dev); skipping "
                  "path (h)", flush=True)
        else:
            print("relay bench: building path (h), the exported C++ node (catkin_make)...", flush=True)
            try:
                built = exported.build("ros1", workdir, [ld.kind for ld in load_list], TOPIC_OUT)
            except BenchError as error:
                print(f"bench: {error}", file=sys.stderr, flush=True)
                return 1
            routes = [*routes, exported_route(built)]

    began = time.monotonic()
    print(f"relay bench: {len(routes)} paths x {len(load_list)} messages x {repeats} repeats", flush=True)
    try:
        cells = run_all(routes, load_list, repeats, lambda line: print(line, flush=True), attempts=opts.attempts)
    except KeyboardInterrupt:  # run_all has stopped every process it started
        print("relay bench interrupted", file=sys.stderr)
        return 130
    text = table(cells, routes, load_list, repeats)
    checks = [] if opts.recipes else check_targets(cells)
    if checks:
        text += "\n\nTargets (issues 3 and 26):\n\n" + "\n".join(target_lines(checks))
        keep("ros1_relay", checks)
    text += f"\n\nWhole run: {time.monotonic() - began:.0f} s.\n"
    out = opts.out or RESULTS / ("relay-recipes.md" if opts.recipes else "relay.md")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    print("\n" + text)
    print(f"(saved to {out})")
    failed = any(c.error for c in cells) or any(f.passed is False for f in checks)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
