"""The history file: a line per change, the user's alone, nothing lost if the disk says no
(:mod:`ipyros.core.journal`)."""

from __future__ import annotations

import os
import stat
import time

import pytest

from ipyros.core import journal


def test_changes_are_written_as_they_happen_and_read_back(tmp_path):
    kept = journal.Journal(tmp_path / "history")
    kept.append(journal.Change(1.0, "/n", "create()"))
    kept.append(journal.Change(2.0, "/n", "timer t every 1 s -> tick", slot="timer t", version=1, handler="tick",
                               source="def tick():\n    pass\n"))
    assert kept.path is not None and kept.path.parent == tmp_path / "history"
    changes = journal.read(kept.path)  # before close: each line is on disk already
    assert [c.change for c in changes] == ["create()", "timer t every 1 s -> tick"]
    assert changes[1].source == "def tick():\n    pass\n" and changes[0].slot is None
    kept.close()


def test_the_files_are_the_users_alone(tmp_path):
    kept = journal.Journal(tmp_path / "history")
    kept.append(journal.Change(1.0, "/n", "params['token'] = 'secret'"))
    assert stat.S_IMODE(os.stat(tmp_path / "history").st_mode) == 0o700
    assert stat.S_IMODE(os.stat(kept.path).st_mode) == 0o600
    kept.close()


def test_two_sessions_in_one_second_get_two_files(tmp_path):
    first, second = journal.Journal(tmp_path), journal.Journal(tmp_path)
    for kept in (first, second):
        kept.append(journal.Change(1.0, "/n", "create()"))
    assert first.path != second.path
    first.close()
    second.close()


def test_a_directory_that_cannot_be_written_fails_once_then_keeps_quiet(tmp_path):
    blocked = tmp_path / "file"
    blocked.write_text("not a directory")
    kept = journal.Journal(blocked / "history")
    with pytest.raises(OSError):
        kept.append(journal.Change(1.0, "/n", "create()"))
    kept.append(journal.Change(2.0, "/n", "shutdown()"))  # off now: no second error
    assert kept.failed


def test_a_torn_last_line_is_skipped(tmp_path):
    path = tmp_path / "h.jsonl"
    path.write_text('{"time": 1.0, "node": "/n", "change": "create()"}\n{"time": 2.0, "node": "/n", "cha')
    assert [c.change for c in journal.read(path)] == ["create()"]


def test_the_default_directory_follows_the_environment(monkeypatch, tmp_path):
    monkeypatch.setenv(journal.ENV_DIR, str(tmp_path / "mine"))
    assert journal.default_dir() == tmp_path / "mine"


@pytest.fixture
def syncs(monkeypatch):
    """Every sync of a history file to the disk, counted (os.fsync as the journal calls it)."""
    counted: list[int] = []
    real = os.fsync
    monkeypatch.setattr(journal.os, "fsync", lambda fd: (counted.append(fd), real(fd)))
    return counted


def test_lines_written_together_share_one_sync_within_a_moment(tmp_path, syncs):
    kept = journal.Journal(tmp_path)
    for n in range(50):  # 150 nodes shut down: a line each
        kept.append(journal.Change(float(n), f"/n{n}", "shutdown()"))
    assert len(journal.read(kept.path)) == 50  # handed to the system at once: an interpreter crash loses none
    deadline = time.monotonic() + 10 * journal.SYNC_WITHIN + 5
    while not syncs and time.monotonic() < deadline:
        time.sleep(0.01)
    assert 1 <= len(syncs) <= 2, f"the fifty lines are synced together within a moment, not {len(syncs)} times"
    before = len(syncs)
    kept.append(journal.Change(51.0, "/n", "create()"))
    kept.close()  # what is left is synced as the file closes
    assert len(syncs) >= before + 1


def test_a_sync_that_fails_is_raised_once_by_the_next_change(tmp_path, monkeypatch):
    def broken(fd):
        raise OSError(5, "Input/output error")

    monkeypatch.setattr(journal.os, "fsync", broken)
    kept = journal.Journal(tmp_path)
    kept.append(journal.Change(1.0, "/n", "create()"))
    deadline = time.monotonic() + 10 * journal.SYNC_WITHIN + 5
    with pytest.raises(OSError, match="Input/output error"):
        while time.monotonic() < deadline:
            kept.append(journal.Change(2.0, "/n", "timer t every 1 s -> tick"))
            time.sleep(0.01)
    kept.append(journal.Change(3.0, "/n", "shutdown()"))  # off now: no second error
    assert kept.failed
    kept.close()


def test_a_change_never_waits_for_a_slow_disk(tmp_path, monkeypatch):
    """The sync runs outside the journal's lock: a change made while the disk takes its time is written at once
    (a handler edited at the prompt does not wait for a slow SD card), and close() still syncs it."""
    import threading

    syncing, release = threading.Event(), threading.Event()
    real = os.fsync

    def slow(fd):
        syncing.set()
        release.wait(10)
        real(fd)

    monkeypatch.setattr(journal.os, "fsync", slow)
    kept = journal.Journal(tmp_path)
    kept.append(journal.Change(1.0, "/n", "create()"))
    assert syncing.wait(10), "the first line was never synced"
    written = threading.Thread(target=kept.append, args=(journal.Change(2.0, "/n", "shutdown()"),))
    written.start()
    written.join(2)
    try:
        assert not written.is_alive(), "a change waited for the sync of the one before"
        assert len(journal.read(kept.path)) == 2
    finally:
        release.set()
        written.join(10)
        kept.close()
