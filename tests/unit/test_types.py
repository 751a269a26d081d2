"""The types of the layers below the backends (core, processes, files, node), checked by mypy with the settings of
pyproject.toml's [tool.mypy]: a Protocol the engine no longer fits, an Optional read as if always there, a seam
typed wrong is found here, before any ROS runs."""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def test_the_lower_layers_type_check(tmp_path):
    api = pytest.importorskip("mypy.api")
    # its cache in a folder of the test's own: nothing is left in the clone
    out, err, status = api.run(["--config-file", str(ROOT / "pyproject.toml"), "--cache-dir", str(tmp_path),
                                "--no-error-summary", *(str(ROOT / "ipyros" / d) for d in
                                                        ("core", "processes", "files", "node"))])
    assert status == 0, out + err
