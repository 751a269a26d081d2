"""Leaving IPython while a node's timer writes is quiet: no traceback of a last write to a closed publisher."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

SCRIPT = """
from ipyros import rosNode
from std_msgs.msg import String
nd = rosNode("quiet_exit_timer")
nd.new.publish("/quiet_exit/chatter", msgType=String).create()
nd.timer(0.005, lambda: nd.write("/quiet_exit/chatter", String(data="x")))
other = rosNode("quiet_exit_other").new.subscribe("/quiet_exit/chatter", handler=lambda m: None,
                                                  msgType=String).create()
import time
time.sleep(1.0)
print("leaving", flush=True)
"""


def test_leaving_while_a_timer_writes_prints_no_traceback(session, tmp_path: Path):
    script = tmp_path / "timer.py"
    script.write_text(SCRIPT)
    for attempt in range(3):  # the race is at exit: try it a few times
        done = subprocess.run([sys.executable, "-m", "IPython", "--ext", "ipyros", "--no-banner", "-c",
                               f"%run -i {script}"], capture_output=True, text=True, timeout=90,
                              env={**__import__("os").environ, "IPYROS_HISTORY_DIR": str(tmp_path / "history")})
        assert "leaving" in done.stdout, done.stdout + done.stderr
        assert "Traceback" not in done.stderr and "failed" not in done.stderr, done.stderr
