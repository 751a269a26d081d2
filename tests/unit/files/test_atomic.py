"""A file written whole or not at all (:mod:`ipyros.files.atomic`), pure: readers never see half of it, and a write
that fails leaves the file as it was and no temporary file beside it."""

from __future__ import annotations

import os

import pytest

from ipyros.core.errors import IpyrosError
from ipyros.files.atomic import write_atomic


def test_a_file_is_written_whole_with_its_mode_and_nothing_left_beside_it(tmp_path):
    path = write_atomic(tmp_path / "node.py", "print('hi')\n", mode=0o755)
    assert path == tmp_path / "node.py" and path.read_text() == "print('hi')\n"
    assert path.stat().st_mode & 0o777 == 0o755
    assert os.listdir(tmp_path) == ["node.py"]


def test_a_write_that_fails_changes_nothing_and_says_so_in_one_line(tmp_path):
    path = tmp_path / "kept.py"
    path.write_text("before\n")

    def full_disk(*_):
        raise OSError(28, "No space left on device")

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(os, "fsync", full_disk)  # the text written, not yet on the disk: where a full disk says so
        with pytest.raises(IpyrosError, match=r"^cannot write .*kept\.py: No space left on device; nothing was "
                                              r"changed there$"):
            write_atomic(path, "after\n")
    assert path.read_text() == "before\n" and os.listdir(tmp_path) == ["kept.py"]


def test_a_folder_that_is_not_there_is_one_line(tmp_path):
    with pytest.raises(IpyrosError, match=r"^cannot write .*/missing/x\.py: No such file or directory$"):
        write_atomic(tmp_path / "missing" / "x.py", "x")
