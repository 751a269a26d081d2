"""A handler version's source and time as a saved file keeps them, and compiled again when chosen
(:mod:`ipyros.core.versions`)."""

from __future__ import annotations

import pytest

from ipyros.core import versions
from ipyros.core.errors import IpyrosError


def named_handler(msg):
    return msg * 2


def test_the_source_of_a_def_and_none_for_a_builtin():
    assert versions.source_of(named_handler).startswith("def named_handler(msg):")
    assert versions.source_of(print) is None
    assert versions.name_of(named_handler) == "named_handler"


def test_a_version_kept_as_source_is_compiled_in_the_namespace_of_the_handler_serving_now():
    version = versions.HandlerVersion(1, 0.0, "scaled", "def scaled(msg):\n    return msg * GAIN\n")
    function = versions.compile_version(version, {"GAIN": 3}, "n /x")
    assert function(2) == 6
    with pytest.raises(IpyrosError, match="has no source to run again"):
        versions.compile_version(versions.HandlerVersion(2, 0.0, "lost", None), {}, "n /x")


def test_times_as_saved():
    version = versions.HandlerVersion(1, versions.parse_time("2026-11-21 10:02:03"), "h", "")
    assert version.when == "2026-11-21 10:02:03"
    with pytest.raises(IpyrosError, match="is not a date and time like"):
        versions.parse_time("yesterday")


def test_the_name_a_source_defines():
    assert versions.defined_name("def on_pose(msg):\n    pass\n") == "on_pose"
