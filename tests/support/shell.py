"""A real IPython InteractiveShell for tests, with ipyros loaded, and helpers to drive it.

Import the fixtures into a test module (``from shell import ip  # noqa: F401``). ``ip``
depends on the run's ``session`` (either ROS), so the shell works against the test
master or DDS domain, and its DSL nodes live in the pytest process.
"""

from __future__ import annotations

import _thread
import atexit
import contextlib
import os
import shutil
import threading
from typing import Iterator, Optional

import pytest
from IPython.core.interactiveshell import ExecutionResult, InteractiveShell
from traitlets.config import Config


def end_shell(shell: InteractiveShell) -> None:
    """End a test's shell now as its exit hook would at the interpreter's exit (history closed, its temporary files
    removed), but without the full garbage collection that hook's reset does: one per shell of the run, with the
    heap a whole run leaves, they took 110 s at the end of the ROS 1 layer."""
    atexit.unregister(shell.atexit_operations)
    if shell.history_manager is not None:
        shell.history_manager.end_session()
        shell.history_manager.close()
    for path in shell.tempfiles:
        path.unlink(missing_ok=True)
    for folder in shell.tempdirs:
        shutil.rmtree(folder, ignore_errors=True)
    shell.tempfiles, shell.tempdirs = [], []


@contextlib.contextmanager
def interactive_shell(config: Optional[Config] = None, load: bool = True) -> Iterator[InteractiveShell]:
    """A fresh shell (history in memory), ipyros loaded if ``load``; unloaded and cleared after."""
    config = Config(config) if config is not None else Config()
    config.HistoryManager.hist_file = ":memory:"
    config.InteractiveShell.colors = "nocolor"  # assertions read plain text
    InteractiveShell.clear_instance()
    shell = InteractiveShell.instance(config=config)
    columns = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = "200"  # rich's width off a terminal: wide, so table rows stay on one line
    try:
        if load:
            shell.run_line_magic("load_ext", "ipyros")
        yield shell
    finally:
        if "ipyros" in shell.extension_manager.loaded:
            shell.run_line_magic("unload_ext", "ipyros")
        end_shell(shell)
        InteractiveShell.clear_instance()
        if columns is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = columns


@pytest.fixture
def ip(session) -> Iterator[InteractiveShell]:
    """An InteractiveShell with ipyros loaded, on the run's ROS. The nodes its cells created are shut down
    after the test (as ``make_node``'s are): a node left running would be the next test's."""
    before = set(session.nodes.values())
    with interactive_shell() as shell:
        try:
            yield shell
        finally:
            for engine in [e for e in list(session.nodes.values()) if e not in before and e.created]:
                engine.shutdown()


def run(shell: InteractiveShell, cell: str) -> ExecutionResult:
    """Run ``cell`` as if typed at the prompt (history and post_run_cell included)."""
    return shell.run_cell(cell, store_history=True)


def ok(shell: InteractiveShell, cell: str) -> ExecutionResult:
    """Run ``cell``; fail the test if it raised."""
    result = run(shell, cell)
    if not result.success:
        raise AssertionError(f"{cell!r} failed: {result.error_before_exec or result.error_in_exec!r}")
    return result


def error_of(shell: InteractiveShell, cell: str) -> BaseException:
    """Run ``cell``, which must fail; its exception."""
    result = run(shell, cell)
    error = result.error_before_exec or result.error_in_exec
    assert error is not None, f"{cell!r} should have failed"
    return error


@contextlib.contextmanager
def ctrl_c_after(seconds: float) -> Iterator[None]:
    """Press Ctrl-C (KeyboardInterrupt in the main thread) after ``seconds``, unless the block ended."""
    timer = threading.Timer(seconds, _thread.interrupt_main)
    timer.start()
    try:
        yield
    finally:
        timer.cancel()
