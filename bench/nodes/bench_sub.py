"""The bench's subscriber: records, per message, its index and its one-way latency.

    bench_sub.py TOPIC KIND REPORT_PATH

Subscribes with rospy.AnyMsg, an unbounded queue, a read size just under glibc's mmap
threshold (see rospy_relay.READ_SIZE) and
TCP_NODELAY requested from whoever publishes (the same request for every path), and
reads stamp and index straight from the bytes: the cheapest subscriber rospy allows,
so that it is not what limits the paths it compares.

Commands on standard input: ``count`` (messages so far), ``report`` (write the
record to REPORT_PATH as JSON, answer ``reported``), ``quit``.
"""

from __future__ import annotations

import json
import sys
import time

import nodeio
import rospy
import wire


class Recorder:
    def __init__(self, kind: str) -> None:
        self.handled_check = wire.KINDS[kind].handled
        self.index: list[int] = []
        self.latency_ns: list[int] = []
        self.received_ns: list[int] = []
        self.handled = 0
        self.header: dict[str, str] = {}

    def __call__(self, raw: rospy.AnyMsg) -> None:
        now = time.time_ns()
        buff = raw._buff
        index, stamp = wire.read_stamp(buff)
        self.index.append(index)
        self.latency_ns.append(now - stamp)
        self.received_ns.append(now)
        if self.handled_check(buff):
            self.handled += 1
        if not self.header:
            self.header = dict(raw._connection_header)

    def report(self, path: str) -> str:
        record = {"index": self.index, "latency_ns": self.latency_ns, "received_ns": self.received_ns,
                  "handled": self.handled, "header": self.header}
        with open(path, "w") as out:
            json.dump(record, out)
        return "reported"


def main() -> None:
    topic, kind, report_path = sys.argv[1], sys.argv[2], sys.argv[3]
    nodeio.start("bench_sub")
    recorder = Recorder(kind)
    rospy.Subscriber(topic, rospy.AnyMsg, recorder, queue_size=None, buff_size=127 * 1024, tcp_nodelay=True)
    nodeio.say("ready")
    nodeio.serve({"count": lambda: len(recorder.index), "report": lambda: recorder.report(report_path)})


if __name__ == "__main__":
    main()
