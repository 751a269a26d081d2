"""A small tmux driver: run a program in a real terminal of fixed size, type into it, read the screen.

End-to-end tests use it to drive the terminal IPython as a person would: keys go in
through ``tmux send-keys``, the screen comes back through ``tmux capture-pane``.

Each :class:`Terminal` runs on a tmux server of its own (``tmux -S <socket>`` in a
temporary directory of its own) with a session name of its own, so a test touches
nothing of anyone else's: not a user's tmux, not another test's. When its one session
ends (the program exits, or :meth:`Terminal.close` kills it) that server exits by
itself, and :meth:`Terminal.close` removes the directory.

    with Terminal("e2e_demo", ["python3", "-q"], env=env) as term:
        term.wait_for(">>> ")
        term.type("1 + 1")
        term.press("Enter")
        term.wait_for("2")

The program is run directly (argv, not a shell line), so :attr:`Terminal.pid` is the
program itself: a test can check that it, and whatever it started, have ended.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import tempfile
import time
import uuid
from pathlib import Path
from typing import Callable, Mapping, Optional, Sequence, TypeVar, Union

T = TypeVar("T")

#: A screen predicate: given the screen's lines, something truthy when the wait is over.
ScreenCheck = Callable[[list[str]], T]


class Terminal:
    """One program in a detached tmux session of ``width`` x ``height`` cells."""

    def __init__(self, name: str, argv: Sequence[str], env: Mapping[str, str], width: int = 160,
                 height: int = 50) -> None:
        # Unique per instance even when two tests pick the same name.
        self.name = f"{name}_{os.getpid()}_{uuid.uuid4().hex[:8]}"
        self.argv = list(argv)
        self.env = {k: v for k, v in env.items() if k != "TMUX"}  # not "nested" in a tmux we run under
        self.width, self.height = width, height
        self.pid: Optional[int] = None
        self.server_pid: Optional[int] = None
        self._started: dict[int, Optional[str]] = {}
        self._socket_dir = tempfile.mkdtemp(prefix="ipyros-tmux-")  # short: a socket path has a length limit

    # -- lifecycle ----------------------------------------------------------------------------
    def start(self) -> "Terminal":
        self._tmux("new-session", "-d", "-s", self.name, "-x", str(self.width), "-y", str(self.height),
                   *self.argv)
        # The pane stays after the program exits only if remain-on-exit is on; it is off by default.
        self.pid = int(self._tmux("display-message", "-p", "-t", self.name, "#{pane_pid}"))
        self.server_pid = int(self._tmux("display-message", "-p", "-t", self.name, "#{pid}"))
        # Each pid with its start time: a pid reused after our process ended is not ours to kill.
        self._started = {pid: _start_time(pid) for pid in (self.pid, self.server_pid)}
        return self

    def alive(self) -> bool:
        """Whether the session still exists (it ends when its program exits)."""
        return self._tmux("has-session", "-t", self.name, check=False) is not None

    def close(self, timeout: float = 10.0) -> None:
        """Kill the session, then make sure its program and tmux server are gone.

        tmux sends the program SIGHUP; one that ignores it is killed by its pid after
        ``timeout`` seconds (it is ours: we started it).
        """
        if self.alive():
            self._tmux("kill-session", "-t", self.name, check=False)
        for pid, started in self._started.items():
            if not _gone(pid, started, timeout):
                os.kill(pid, signal.SIGKILL)
                _gone(pid, started, timeout)
        shutil.rmtree(self._socket_dir, ignore_errors=True)

    def __enter__(self) -> "Terminal":
        try:
            return self.start()
        except BaseException:
            self.close()
            raise

    def __exit__(self, *exc) -> None:
        self.close()

    # -- keys -----------------------------------------------------------------------------------
    def type(self, text: str) -> None:
        """Type ``text`` literally (no key names; a newline in it would be a key press: avoid it)."""
        self._tmux("send-keys", "-t", self.name, "-l", text)

    def press(self, *keys: str, times: int = 1) -> None:
        """Press keys by tmux name (``Enter``, ``Tab``, ``Left``, ``C-u``, ``End``), each ``times`` times."""
        self._tmux("send-keys", "-t", self.name, "-N", str(times), *keys)

    def line(self, text: str) -> None:
        """Type one line and press Enter."""
        self.type(text)
        self.press("Enter")

    # -- screen ----------------------------------------------------------------------------------
    def screen(self, history: bool = False, joined: bool = False) -> list[str]:
        """The visible screen, one string per row, trailing blanks stripped (no colours).

        With ``history``, the rows scrolled off the top come first (all tmux keeps). With ``joined``, a line the
        terminal wrapped is one string again (longer than the width: how a test sees that a line did not fit).
        """
        start = ["-S", "-"] if history else []
        out = self._tmux("capture-pane", "-p", *start, *(["-J"] if joined else []), "-t", self.name, check=False)
        rows = [row.rstrip() for row in (out or "").split("\n")]
        return rows if history or joined else rows[: self.height]

    def resize(self, width: int) -> None:
        """Make the terminal ``width`` cells wide (the program hears SIGWINCH, as when a window is dragged)."""
        self._tmux("resize-window", "-t", self.name, "-x", str(width), "-y", str(self.height))
        self.width = width

    def last_line(self) -> str:
        """The last non-blank row of the screen: where the prompt sits."""
        return next((row for row in reversed(self.screen()) if row.strip()), "")

    def wait_for(self, check: Union[str, ScreenCheck[T]], timeout: float = 20.0, what: Optional[str] = None,
                 interval: float = 0.05) -> Union[list[str], T]:
        """Poll the screen until ``check`` (a text on it, or a predicate on its rows) holds.

        Returns the screen (for a text) or the predicate's value. On timeout, fails with
        the screen as it was, which is what one needs to see why.
        """
        if isinstance(check, str):
            text = check
            what = what or repr(text)

            def check(rows: list[str]) -> Union[list[str], None]:
                return rows if any(text in row for row in rows) else None

        deadline = time.monotonic() + timeout
        while True:
            rows = self.screen()
            value = check(rows)
            if value:
                return value
            if time.monotonic() > deadline:
                shown = "\n".join(rows).rstrip()
                raise AssertionError(f"timed out after {timeout}s waiting for {what or 'the screen'}; "
                                     f"the screen:\n{shown}")
            time.sleep(interval)

    # -- tmux -----------------------------------------------------------------------------------
    def _tmux(self, *args: str, check: bool = True) -> Optional[str]:
        """Run one tmux command on this terminal's own server; its output, or None if it failed."""
        done = subprocess.run(["tmux", "-S", os.path.join(self._socket_dir, "tmux"), *args], env=self.env,
                              capture_output=True, text=True, check=False, timeout=30)
        if done.returncode != 0:
            if check:
                raise RuntimeError(f"tmux {' '.join(args[:1])} failed: {done.stderr.strip()}")
            return None
        return done.stdout.rstrip("\n")


def descendants(pid: int) -> set[int]:
    """The living processes below ``pid`` (children, their children, ...), from /proc."""
    parents: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if fields[0] != "Z":
            parents.setdefault(int(fields[1]), []).append(int(entry.name))
    found: set[int] = set()
    todo = [pid]
    while todo:
        for child in parents.get(todo.pop(), []):
            if child not in found:
                found.add(child)
                todo.append(child)
    return found


def _start_time(pid: int) -> Optional[str]:
    """When ``pid`` started (clock ticks since boot, from /proc), or None if it is gone or a zombie."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return None
    return None if fields[0] == "Z" else fields[19]  # field 22 of stat; 3 fields precede the split


def _gone(pid: int, started: Optional[str], timeout: float) -> bool:
    """Wait up to ``timeout`` s for the process ``pid`` that started at ``started`` to end; whether it did."""
    deadline = time.monotonic() + timeout
    while started is not None and _start_time(pid) == started:
        if time.monotonic() > deadline:
            return False
        time.sleep(0.05)
    return True


# -- an IPython prompt in the terminal ----------------------------------------------------

PROMPT = re.compile(r"^In \[(\d+)\]: ?(.*)$")


def prompt(rows: list[str]):
    """The prompt line (number, input) if the last non-blank row of the screen is a prompt."""
    last = next((row for row in reversed(rows) if row.strip()), "")
    match = PROMPT.match(last)
    return (int(match[1]), match[2]) if match else None


def prompt_reads(term: Terminal, text: str, timeout: float = 20.0) -> int:
    """Wait until the prompt at the bottom holds exactly ``text``; its number."""
    number, _ = term.wait_for(lambda rows: (p := prompt(rows)) and p[1] == text and p,
                              timeout=timeout, what=f"the prompt to read {text!r}")
    return number


def run(term: Terminal, line: str, timeout: float = 20.0) -> None:
    """Type ``line`` at the prompt, run it, and wait for the next prompt."""
    number = prompt_reads(term, "", timeout)
    term.line(line)
    term.wait_for(lambda rows: (p := prompt(rows)) and p[0] > number, timeout=timeout,
                  what=f"the prompt after {line!r}")
