"""Start ``tests/nodes/many_topics.py`` as a real ROS peer for the graph and completion tests."""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
from pathlib import Path
from typing import Iterator

SCRIPT = Path(__file__).resolve().parents[1] / "nodes" / "many_topics.py"


@contextlib.contextmanager
def many_topics(node: str, count: int, prefix: str = "/many/t", type: str = "std_msgs/String",
                subscribe: tuple[str, ...] = (), topics: dict[str, str] | None = None) -> Iterator[subprocess.Popen]:
    """A subprocess node advertising ``count`` topics ``prefix0000``... and ``topics`` {name: type};
    stopped (SIGTERM) on exit."""
    cmd = [sys.executable, str(SCRIPT), node, str(count), "--prefix", prefix, "--type", type]
    if topics:
        cmd += ["--topics", *(f"{name}={t}" for name, t in topics.items())]
    if subscribe:
        cmd += ["--subscribe", *subscribe]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=dict(os.environ))
    try:
        yield proc
    finally:
        stop(proc)


def stop(proc: subprocess.Popen) -> None:
    """SIGTERM (rospy then unregisters from the master), SIGKILL if it lingers."""
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
