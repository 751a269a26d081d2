"""Run ROS peer nodes (scripts in tests/ros1/peers/, or a suite's own ``PEERS``) as subprocesses and read what they print."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

from support import wait_for

PEERS = Path(__file__).resolve().parents[1] / "ros1" / "peers"


class Peer:
    """A peer process; ``lines`` fills as it prints. Use as a context manager.

    ``script`` is found in ``PEERS`` (a subclass may point elsewhere: the ROS 2 suite does).
    """

    PEERS = PEERS

    def __init__(self, script: str, *args: str) -> None:
        path = self.PEERS / script  # an absolute path stays as it is
        # One that reads its stdin ends when it closes, and may say its last words then (a count); any other is
        # asked with Ctrl-C at once: waiting for it to notice a stdin it never reads only wastes the test's time.
        self.ends_at_eof = "sys.stdin" in path.read_text()
        self.proc = subprocess.Popen(
            [sys.executable, str(path), *map(str, args)],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        for line in self.proc.stdout:  # type: ignore[union-attr]
            self.lines.append(line.rstrip("\n"))

    def wait_line(self, text: str, timeout: float = 20.0) -> str:
        return wait_for(lambda: next((line for line in self.lines if text in line), None),
                        timeout, what=f"{text!r} from {self.proc.args[1]} (got {self.lines[-5:]})")

    def stop(self) -> None:
        """End the peer so that it unregisters from the master (a killed node stays listed there
        and misleads the tests that come after): stdin closed, then Ctrl-C, then SIGTERM/SIGKILL."""
        try:
            self.proc.stdin.close()  # type: ignore[union-attr]
        except OSError:
            pass
        steps = ((lambda: None, 2.0 if self.ends_at_eof else 0.0),
                 (lambda: self.proc.send_signal(signal.SIGINT), 5.0), (self.proc.terminate, 5.0), (self.proc.kill, 10.0))
        for ask, wait in steps:
            if self.proc.poll() is not None:
                break
            ask()
            try:
                self.proc.wait(wait)
            except subprocess.TimeoutExpired:
                continue
        self._reader.join(5)

    def __enter__(self) -> "Peer":
        return self

    def __exit__(self, *exc) -> None:
        self.stop()


def stop_together(peers: list[Peer]) -> None:
    """Stop ``peers`` side by side: each takes a moment to unregister, and the moments need not add up."""
    stopping = [threading.Thread(target=peer.stop) for peer in peers]
    for thread in stopping:
        thread.start()
    for thread in stopping:
        thread.join()
