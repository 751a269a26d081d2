"""How a basenode is started: its command line on each ROS (no process is run here)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

from ipyros.processes.basenode import BaseProcess, exit_reason, param_arg, plain, python_command, script_command
from ipyros.core.errors import BaseNodeError


def argv(ros2: bool, **options) -> list[str]:
    return BaseProcess("/opt/ws/lib/pkg/node", ["--verbose"], log_path=os.devnull, ros2=ros2, **options).argv[1:]


def test_ros1_argv_has_name_namespace_remaps_and_params():
    assert argv(False, node_name="planner", namespace="/robot1/", remaps={"/scan": "/w/base/scan"},
                params={"rate": 5, "frame": "map"}) == [
        "--verbose", "__name:=planner", "__ns:=/robot1/", "/scan:=/w/base/scan", "_rate:=5", "_frame:=map"]


def test_ros2_argv_puts_them_after_ros_args():
    assert argv(True, node_name="planner", namespace="/robot1/", remaps={"/scan": "/w/base/scan"},
                params={"rate": 5.0}) == [
        "--verbose", "--ros-args", "-r", "__node:=planner", "-r", "__ns:=/robot1", "-r", "/scan:=/w/base/scan",
        "-p", "rate:=5.0"]


def test_ros2_argv_without_rules_has_no_ros_args():
    assert argv(True) == ["--verbose"]


@pytest.mark.parametrize("name, value, arg", [
    ("rate", 5, "_rate:=5"), ("~gain", 2.5, "_gain:=2.5"), ("on", True, "_on:=true"),
    ("frame", "map", "_frame:=map"), ("code", "5", "_code:='5'"), ("flag", "true", "_flag:='true'"),
    ("list", [1, 2], "_list:=[1, 2]"), ("empty", "", "_empty:=''"),
])
def test_params_on_the_command_line_read_back_as_given(name, value, arg):
    assert param_arg(name, value) == arg


def test_the_environment_and_master_uri(monkeypatch):
    process = BaseProcess("/bin/true", log_path=os.devnull, master_uri="http://127.0.0.1:1/", env={"X": "1"})
    assert process.env["ROS_MASTER_URI"] == "http://127.0.0.1:1/"
    assert process.env["X"] == "1" and process.env["PYTHONUNBUFFERED"] == "1"


def test_python_scripts_run_with_this_interpreter(tmp_path: Path):
    script = tmp_path / "node.py"
    script.write_text("#!/usr/bin/env python3\nprint('hi')\n")
    assert python_command(script, ["a"]) == (Path(sys.executable), [str(script), "a"])
    binary = tmp_path / "node"
    binary.write_bytes(b"\x7fELF...")
    assert python_command(binary, ["a"]) == (binary, ["a"])


def test_a_script_by_path(tmp_path: Path):
    script = tmp_path / "talker.py"
    script.write_text("print('hi')\n")
    assert script_command(str(script)) == (Path(sys.executable), [str(script)])
    with pytest.raises(BaseNodeError, match="needs its package"):
        script_command("talker")
    with pytest.raises(BaseNodeError, match="no such file"):
        script_command(str(tmp_path / "missing.py"))


def test_exit_reasons_and_log_lines():
    assert exit_reason(3) == "exited with code 3"
    assert exit_reason(-11) == "killed by SIGSEGV"
    assert plain("\x1b[31m[ERROR] bad\x1b[0m") == "[ERROR] bad"
