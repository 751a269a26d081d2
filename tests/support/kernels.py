"""A Jupyter kernel (ipykernel) of the venv's Python for tests, driven over the messaging protocol.

The kernel gets a kernelspec of our own (written to a temporary directory: the one
installed in the venv runs whatever ``python`` is on PATH), and a home, IPYTHONDIR and
ROS_HOME of its own, on the test master. Import the fixture: ``from kernels import kernel``.
"""

from __future__ import annotations

import ast
import json
import os
import re
import sys
from dataclasses import dataclass, field
from typing import Any

import pytest
from helpers import pid_alive
from jupyter_client import KernelManager
from jupyter_client.kernelspec import KernelSpecManager
from support import wait_for

TIMEOUT = 30  # per request: generous, finite


@dataclass
class Cell:
    """What one execute request brought back: its reply and its IOPub messages."""

    reply: dict[str, Any]
    messages: list[dict[str, Any]] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return self.reply["status"] == "ok"

    def outputs(self, *kinds: str) -> list[dict[str, Any]]:
        """The contents of the messages of these types (stream, display_data, execute_result, error)."""
        return [m["content"] for m in self.messages if m["msg_type"] in kinds]

    def stdout(self) -> str:
        return "".join(c["text"] for c in self.outputs("stream") if c["name"] == "stdout")

    def said(self) -> list[str]:
        """The ``ipyros:`` lines of stdout, without the handler's prints.

        While a node runs its handler prints from a ROS thread, maybe into this cell, maybe
        between the text of a line and its newline (``print`` writes them one by one).
        """
        text = re.sub(r"(OLD|NEW) \d+", "", self.stdout())
        return [line for line in text.splitlines() if line.startswith("ipyros:")]

    def shown(self, mime: str = "text/plain") -> str:
        """Everything displayed (display_data and the cell's result) in ``mime``, ANSI colours removed."""
        texts = [c["data"].get(mime, "") for c in self.outputs("display_data", "execute_result")]
        return re.sub(r"\x1b\[[0-9;]*m", "", "\n".join(texts))

    def updated(self, display_id: str) -> str:
        """The last text this cell's run put in the display ``display_id`` (of this cell or an earlier one)."""
        texts = [c["data"].get("text/plain", "") for c in self.outputs("update_display_data")
                 if c.get("transient", {}).get("display_id") == display_id]
        return texts[-1] if texts else ""

    def payload(self, source: str) -> dict[str, Any]:
        return next(p for p in self.reply.get("payload", []) if p["source"] == source)


class Kernel:
    """A blocking client of one running kernel."""

    def __init__(self, manager: KernelManager) -> None:
        self.manager = manager
        self.client = manager.client()
        self.pid = manager.provisioner.pid

    def shutdown(self) -> None:
        """Ask the kernel to shut down (killed if it does not in time); wait until its process is gone."""
        if self.manager.has_kernel:
            self.client.stop_channels()
            self.manager.shutdown_kernel(now=False)
        wait_for(lambda: not pid_alive(self.pid), timeout=20, what="the kernel process to exit")

    def run(self, code: str, timeout: float = TIMEOUT) -> Cell:
        messages: list[dict[str, Any]] = []
        reply = self.client.execute_interactive(code, timeout=timeout, output_hook=messages.append,
                                                stop_on_error=False)
        return Cell(reply["content"], messages)

    def ok(self, code: str, timeout: float = TIMEOUT) -> Cell:
        cell = self.run(code, timeout)
        assert cell.ok, f"{code!r} failed: {cell.reply.get('ename')}: {cell.reply.get('evalue')}"
        return cell

    def value(self, code: str) -> Any:
        """The value of the cell's last expression, a Python literal (read from its repr, not from
        stdout, where a handler's print may fall in the middle of a line)."""
        (result,) = self.ok(code).outputs("execute_result")
        return ast.literal_eval(result["data"]["text/plain"])

    def complete(self, code: str) -> list[str]:
        """The matches a front end gets for TAB at the end of ``code``."""
        return [text for text, _ in self.complete_typed(code)]

    def complete_typed(self, code: str) -> list[tuple[str, str]]:
        """The matches with the type JupyterLab shows beside each (its ``_jupyter_types_experimental``)."""
        reply = self.client.complete(code, len(code), reply=True, timeout=TIMEOUT)["content"]
        assert reply["status"] == "ok", reply
        types = {t["text"]: t.get("type", "") for t in reply.get("metadata", {}).get("_jupyter_types_experimental", [])}
        return [(text, types.get(text, "")) for text in reply["matches"]]


def start_kernel(ros_master: str, tmp_path, name: str = "kernel") -> Kernel:
    """A running ipykernel of the venv's Python, with its own directories under ``tmp_path / name``."""
    tmp_path = tmp_path / name
    specs = tmp_path / "kernels"
    (specs / "ipyros_e2e").mkdir(parents=True)
    (specs / "ipyros_e2e" / "kernel.json").write_text(json.dumps({
        "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
        "display_name": "ipyros e2e", "language": "python"}))
    home = tmp_path / "home"
    home.mkdir()
    env = {**os.environ, "HOME": str(home), "IPYTHONDIR": str(home / ".ipython"),
           "ROS_MASTER_URI": ros_master, "ROS_HOME": str(tmp_path / "ros"),
           "ROS_LOG_DIR": str(tmp_path / "ros" / "log")}
    env.pop("PYTHONSTARTUP", None)
    manager = KernelManager(kernel_name="ipyros_e2e", kernel_spec_manager=KernelSpecManager(kernel_dirs=[str(specs)]),
                            connection_file=str(tmp_path / "connection.json"))
    manager.start_kernel(env=env)
    kernel = Kernel(manager)
    try:
        kernel.client.start_channels()
        kernel.client.wait_for_ready(timeout=60)
    except BaseException:
        kernel.shutdown()
        raise
    return kernel


@pytest.fixture
def kernel(ros_master, tmp_path):
    """A running kernel; shut down (and checked gone) after the test."""
    running = start_kernel(ros_master, tmp_path)
    try:
        yield running
    finally:
        running.shutdown()


