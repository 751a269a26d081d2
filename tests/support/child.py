"""A Python interpreter of its own, driven block by block: for sessions a test must kill or starve.

    with Child(env={"ROS_MASTER_URI": uri}) as child:
        child.run("nd = rosNode('x').create()")
        assert "ipyros:" in child.wait_err("is back")

``run`` sends a block of code, which the child executes in one namespace, and returns what
it printed; an exception in the child raises :class:`ChildError` with its one-line text.
What the child writes on stderr (ipyros's notices) is collected in ``err_lines``.
"""

from __future__ import annotations

import os
import subprocess
import sys
import threading

from support import wait_for

_DONE = "@@ipyros-test-done"
_DRIVER = f"""
import sys, traceback
namespace = {{"__name__": "__main__"}}
block = []
for line in sys.stdin:
    if line.rstrip("\\n") != {_DONE!r}:
        block.append(line)
        continue
    try:
        exec(compile("".join(block), "<test block>", "exec"), namespace)
        print({_DONE!r}, "ok", flush=True)
    except BaseException as error:
        text = str(error).replace("\\n", " ")
        print({_DONE!r}, "error", type(error).__name__ + ":", text, flush=True)
    block = []
"""


class ChildError(Exception):
    """An exception raised by a block the child ran; its text is ``Type: message``."""


class Child:
    def __init__(self, env: dict | None = None, cwd: str | None = None) -> None:
        self.proc = subprocess.Popen([sys.executable, "-u", "-c", _DRIVER], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=cwd,
                                     env={**os.environ, **(env or {})})
        self.out_lines: list[str] = []
        self.err_lines: list[str] = []
        self._readers = [threading.Thread(target=self._read, args=(s, into), daemon=True)
                         for s, into in ((self.proc.stdout, self.out_lines), (self.proc.stderr, self.err_lines))]
        for reader in self._readers:
            reader.start()

    @staticmethod
    def _read(stream, into: list[str]) -> None:
        for line in stream:
            into.append(line.rstrip("\n"))

    def run(self, code: str, timeout: float = 30.0) -> str:
        """Run ``code`` in the child; its output. Raises ChildError if it raised, AssertionError on timeout."""
        start = len(self.out_lines)
        self.proc.stdin.write(code.rstrip("\n") + f"\n{_DONE}\n")
        self.proc.stdin.flush()

        def finished():
            found = next((i for i in range(start, len(self.out_lines)) if self.out_lines[i].startswith(_DONE)), None)
            return ("at", found) if found is not None else ("exited", 0) if self.proc.poll() is not None else None

        how, done = wait_for(finished, timeout, what=f"the child to run {code.splitlines()[0]!r}")
        if how == "exited":
            raise ChildError(f"the child exited with {self.proc.returncode}: {self.err_lines[-5:]}")
        output, status = self.out_lines[start:done], self.out_lines[done][len(_DONE) + 1:]
        if status != "ok":
            raise ChildError(status.removeprefix("error "))
        return "\n".join(output)

    def attempt(self, code: str, timeout: float = 30.0) -> str | ChildError:
        """Run ``code``; its output or the ChildError it raised (a call that hangs fails the test at ``timeout``)."""
        try:
            return self.run(code, timeout)
        except ChildError as error:
            return error

    def wait_err(self, text: str, timeout: float = 20.0) -> str:
        """The first line the child wrote on stderr containing ``text`` (waiting for it)."""
        return wait_for(lambda: next((line for line in self.err_lines if text in line), None), timeout,
                        what=f"{text!r} on the child's stderr (last: {self.err_lines[-3:]})")

    def close(self, timeout: float = 20.0) -> int:
        """End the child as a script ends (stdin closed: its atexit hooks run); SIGKILL if it hangs."""
        if self.proc.poll() is None:
            try:
                self.proc.stdin.close()
            except OSError:
                pass
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        for reader in self._readers:
            reader.join(5)
        return self.proc.returncode

    def __enter__(self) -> "Child":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
