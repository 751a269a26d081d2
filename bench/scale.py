"""Scale benchmark: a session with many DSL nodes and many wrapped basenodes starts, runs and stops cleanly.

    python -m bench.scale                         # 100 DSL nodes, 50 wrapped basenodes (a few minutes)
    python -m bench.scale --nodes 20 --basenodes 5

Run with the venv of the ROS to measure (ROS 1: ``.venv``, a rosmaster of the bench's own on a free port;
ROS 2: ``.venv-ros2``, a DDS domain of the bench's own with discovery kept to this machine). In the
bench's own process, as at a prompt:

1. ``--nodes`` DSL nodes, each ``new.publish`` of a topic and ``new.subscribe`` of another with a handler,
   then ``create()``: the time each ``create()`` takes and the session's resident memory per node;
2. ``--basenodes`` wrapping nodes, each around a stand-in basenode (a real node process that publishes
   nothing: ``bench/nodes/ipyros_bench/idle`` on ROS 1, ``bench/ros2/idle.py`` on ROS 2) with one
   ``reuse.publish`` relay; ``create()`` starts the basenode remapped and waits for it: its time, the
   session's memory per wrapping node and each basenode process's own;
3. a message through every DSL node (one written on each node's output, heard back by the next node's
   handler), so that they are not only declared but working;
4. every node shut down together (``ipyros.shutdown``, what leaving the session does): how long it took (target:
   150 nodes in 5 s), and that no basenode process is left.

The table is printed and saved to bench/results/scale_ros1.md or scale_ros2.md. Exit status 1 if a
node did not start, a message did not go through, or a process was left behind.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any, Callable, Optional

from bench.figures import Figure, keep
from bench.relay import BenchError, Master, memory_mib, stop_cleanly_on_sigterm, wait_until

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"

def rss_mib(pid: int) -> float:
    """A process's resident memory now, MiB; 0 if it is gone."""
    return memory_mib(pid) or 0.0


def alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/status").read_text().split("State:")[1].split()[0] != "Z"
    except (OSError, IndexError):
        return False


def timed(action: Callable[[], Any]) -> float:
    started = time.perf_counter()
    action()
    return time.perf_counter() - started


def run(nodes: int, basenodes: int, ros2: bool, say: Callable[[str], None]
        ) -> tuple[list[tuple[str, str]], bool, list[Figure]]:
    from std_msgs.msg import String

    from ipyros.core.errors import IpyrosError
    from ipyros.dsl import rosNode, shutdown
    from ipyros.node.session import current

    rows: list[tuple[str, str]] = []
    ros = "ROS 2" if ros2 else "ROS 1"
    figures: list[Figure] = []
    ok = True
    heard: dict[int, threading.Event] = {i: threading.Event() for i in range(nodes)}
    dsl: list[Any] = []
    wrapping: list[Any] = []
    me = os.getpid()
    start_mib = 0.0
    try:
        say(f"creating {nodes} DSL nodes ...")
        times = []
        for i in range(nodes):
            node = rosNode(f"scale_n{i:03d}")

            def handler(msg: Any, i: int = i) -> None:  # node i hears node i-1's output
                heard[i].set()

            node.new.publish(f"/scale/t{i:03d}", msgType=String)
            node.new.subscribe(f"/scale/t{(i - 1) % nodes:03d}", handler=handler, msgType=String)
            times.append(timed(node.create))
            dsl.append(node)
            if i == 0:  # the first one also started the session (rospy/rclpy, the graph): not counted per node
                start_mib = rss_mib(me)
        after_nodes = rss_mib(me)
        rows += [("DSL nodes created", f"{nodes}"),
                 ("create() of a DSL node, median / max", f"{statistics.median(times) * 1000:.1f} / "
                                                          f"{max(times) * 1000:.1f} ms"),
                 ("session memory per DSL node", f"{(after_nodes - start_mib) / max(1, nodes - 1) * 1024:.0f} KiB "
                                                 f"({start_mib:.0f} MiB with one node, {after_nodes:.0f} with all)")]
        figures += [Figure(ros, "create() of a DSL node, median", statistics.median(times) * 1000, "ms"),
                    Figure(ros, "session memory per DSL node", (after_nodes - start_mib) / max(1, nodes - 1) * 1024,
                           "KiB")]

        say(f"wrapping {basenodes} basenodes ...")
        times = []
        for i in range(basenodes):
            node = rosNode(f"scale_w{i:03d}")
            if ros2:
                node.baseNode(str(HERE / "ros2" / "idle.py"), name=f"scale_idle{i:03d}")
            else:
                node.baseNode("idle", name=f"scale_idle{i:03d}").basePackage("ipyros_bench")
            node.reuse.publish(f"/scale/w{i:03d}", type=String)
            times.append(timed(node.create))
            wrapping.append(node)
        after_wrap = rss_mib(me)
        pids = [node.base.pid for node in wrapping]
        children = [rss_mib(pid) for pid in pids]
        rows += [("wrapped basenodes started", f"{sum(1 for pid in pids if alive(pid))} of {basenodes}"),
                 ("create() of a wrapping node (starts its basenode), median / max",
                  f"{statistics.median(times):.2f} / {max(times):.2f} s" if times else "-"),
                 ("session memory per wrapping node",
                  f"{(after_wrap - after_nodes) / max(1, basenodes) * 1024:.0f} KiB"),
                 ("a basenode process's memory, median", f"{statistics.median(children):.0f} MiB" if children else "-")]
        ok &= all(alive(pid) for pid in pids)
        per_wrapping_kib = (after_wrap - after_nodes) / max(1, basenodes) * 1024
        figures += [Figure(ros, "session memory per wrapping node", per_wrapping_kib, "KiB")]
        if children:
            figures.append(Figure(ros, "a basenode process's memory, median", statistics.median(children), "MiB"))

        say("a message through every DSL node ...")
        started = time.monotonic()
        for i, node in enumerate(dsl):
            # written until heard: a subscription may still be connecting to its publisher
            wait_until(lambda node=node, i=i: (node.write(f"/scale/t{i:03d}", String(data="hi")),
                                               heard[(i + 1) % nodes].wait(0.05))[1], 30,
                       f"node {(i + 1) % nodes} to hear node {i}", 0.0)
        rows.append(("a message heard through each of the DSL nodes", f"{nodes} of {nodes} in "
                                                                     f"{time.monotonic() - started:.1f} s"))
        figures.append(Figure(ros, "DSL nodes a message went through", nodes, "", "asked", nodes, least=1.0))
    except (BenchError, IpyrosError) as error:  # said in the table; what did start is stopped below
        rows.append(("failed", str(error)))
        ok = False
    finally:
        say("shutting every node down ...")
        pids = [node.base.pid for node in wrapping if node.base is not None and node.base.pid]
        took = timed(lambda: shutdown(*dsl, *wrapping))  # side by side, as leaving the session does
        deadline = time.monotonic() + 10
        while any(alive(pid) for pid in pids) and time.monotonic() < deadline:
            time.sleep(0.05)
        left = [pid for pid in pids if alive(pid)]
        rows += [("shutdown() of every node", f"{took:.1f} s"),
                 ("basenode processes left after shutdown", f"{len(left)}")]
        ok &= not left
        figures += [Figure(ros, "wrapped basenodes started", len(pids), "", "asked", basenodes, least=1.0),
                    Figure(ros, f"shutdown() of {len(dsl) + len(wrapping)} nodes", took, "s",
                           # 150 nodes in 5 s; stopping side by side, a quick run's few nodes still wait for
                           # one basenode's exit (about 0.8 s on ROS 1): its target is that of 50 nodes
                           most=5.0 * max(len(dsl) + len(wrapping), 50) / 150),
                    Figure(ros, "basenode processes left after shutdown", len(left), "", most=0)]
        current().close()
    return rows, ok, figures


def main(argv: Optional[list[str]] = None) -> int:
    stop_cleanly_on_sigterm()
    parser = argparse.ArgumentParser(prog="python -m bench.scale", description=__doc__.split("\n")[0])
    parser.add_argument("--nodes", type=int, default=100, help="DSL nodes (default 100)")
    parser.add_argument("--basenodes", type=int, default=50, help="wrapped basenodes (default 50)")
    parser.add_argument("--quick", action="store_true", help="20 DSL nodes and 5 basenodes")
    opts, _ = parser.parse_known_args(argv)  # `bash run.sh bench` passes the other benches' options too
    if opts.quick:
        opts.nodes, opts.basenodes = 20, 5
    ros2 = importlib.util.find_spec("rospy") is None
    say = lambda line: print(line, flush=True)  # noqa: E731
    with tempfile.TemporaryDirectory(prefix="ipyros-bench-scale-") as tmp:
        workdir = Path(tmp)
        master = None
        if ros2:
            from bench.relay_ros2 import environment

            env = environment()
            os.environ.update({k: env[k] for k in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE",
                                                   "AMENT_PREFIX_PATH")})
            os.environ["IPYROS_ROS"] = "2"
        else:
            master = Master(workdir)
            os.environ.update({k: master.env[k] for k in ("ROS_MASTER_URI", "ROS_IP")})
            # the stand-in basenode's package, found as rosrun finds it
            os.environ["ROS_PACKAGE_PATH"] = os.pathsep.join(
                p for p in (str(HERE / "nodes"), os.environ.get("ROS_PACKAGE_PATH")) if p)
        os.environ.update(ROS_HOME=str(workdir), ROS_LOG_DIR=str(workdir / "log"))
        try:
            rows, ok, figures = run(opts.nodes, opts.basenodes, ros2, say)
        finally:
            if master is not None:
                master.stop()
    text = (f"Scale on {'ROS 2' if ros2 else 'ROS 1'}: {opts.nodes} DSL nodes and {opts.basenodes} wrapped "
            f"basenodes in one session, {os.cpu_count()} cores\n\n| what | measured |\n|---|---|\n"
            + "\n".join(f"| {what} | {value} |" for what, value in rows)
            + f"\n\nStarted, worked and stopped cleanly: {'PASS' if ok else 'FAIL'}\n")
    keep("ros2_scale" if ros2 else "ros1_scale", figures)
    RESULTS.mkdir(exist_ok=True)
    out = RESULTS / ("scale_ros2.md" if ros2 else "scale_ros1.md")
    out.write_text(text)
    print("\n" + text)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
