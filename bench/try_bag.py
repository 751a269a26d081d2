"""``%try ... --bag``: how fast a change is rehearsed on recorded data, against reading the bag alone.

    python -m bench.try_bag            # 100,000 TwistStamped messages, no master needed
    python -m bench.try_bag --quick    # 20,000

Run with the venv of either ROS (``bash run.sh bench`` runs it in both). A bag of the bench's own (ROS 1:
a ``.bag`` file; ROS 2: a rosbag2 folder, MCAP) holds ``--count`` ``TwistStamped`` messages. Two figures,
in this process, one after the other: the messages a second that reading the bag gives (every message
deserialised into this Python's class, :func:`bag_messages` of the session's ROS), and those that
:func:`ipyros.tools.tryout.try_bag` gives running each through a live handler and a candidate, both
trivial (one ``nd.write``), with what they print and write captured and compared. The ratio is what
rehearsing adds to reading. Prints a table and keeps the figures for ``python -m bench.figures``.
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
import tempfile
import time
from pathlib import Path
from typing import Optional

from bench.figures import Figure, keep, machine, table

RESULTS = Path(__file__).resolve().parent / "results"
TOPIC, OUT = "/bench/try_in", "/bench/try_out"


def main(argv: Optional[list[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.try_bag", description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="20,000 messages")
    parser.add_argument("--count", type=int, default=None)
    args, _ = parser.parse_known_args(argv)  # `bash run.sh bench` passes the other benches' options too
    count = args.count or (20000 if args.quick else 100000)
    ros = "ROS 1" if importlib.util.find_spec("rospy") else "ROS 2"
    from geometry_msgs.msg import TwistStamped

    from ipyros import rosNode
    from ipyros.tools.record import bag_module
    from ipyros.tools.tryout import try_bag

    bags = bag_module()
    with tempfile.TemporaryDirectory(prefix="ipyros-bench-try-") as tmp:
        path = Path(tmp) / ("run.bag" if ros == "ROS 1" else "run")
        writer = bags.BagWriter(path)
        for i in range(count):
            msg = TwistStamped()
            msg.twist.linear.x = float(i)
            writer.write(TOPIC, msg)
        writer.close()

        began = time.perf_counter()
        read = sum(1 for _ in bags.bag_messages(path, {TOPIC}))
        read_s = time.perf_counter() - began

        node = rosNode("bench_try")
        node.new.subscribe(TOPIC, handler=lambda m: node.write(OUT, m), msgType=TwistStamped)
        node.new.publish(OUT, msgType=TwistStamped)
        began = time.perf_counter()
        trial = try_bag(node, TOPIC, lambda m: node.write(OUT, m), path)
        trial_s = time.perf_counter() - began
    if read != count or trial.total != count or trial.differing:
        print(f"bench: read {read}, tried {trial.total} ({trial.differing} differing) of {count}", file=sys.stderr)
        return 1
    figures = [Figure(ros, f"%try --bag, two trivial handlers, {count:,} TwistStamped", count / trial_s, "msg/s",
                      "reading the bag alone", count / read_s, least=0.5)]  # at most twice reading it (issue 52)
    text = f"Machine: {machine(ros)}.\n\n{table(figures)}\n"
    keep(f"{ros.lower().replace(' ', '')}_try_bag", figures)
    print(text)
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / f"try_bag_{ros.lower().replace(' ', '')}.md").write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
