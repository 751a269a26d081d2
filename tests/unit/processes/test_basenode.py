"""How a basenode is started: its command line on each ROS (no process is run, no ROS imported here)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

from ipyros.core.errors import BaseNodeError
from ipyros.core.model import BaseModel
from ipyros.processes.basenode import (
    BaseProcess,
    child_env,
    exit_reason,
    param_value,
    plain,
    python_command,
    script_command,
)
from ipyros.ros1 import nodes as ros1_nodes
from ipyros.ros2 import nodes as ros2_nodes


@pytest.fixture
def node_file(tmp_path: Path) -> str:
    path = tmp_path / "node"
    path.write_bytes(b"\x7fELF...")  # a binary: run as it is
    path.chmod(0o755)
    return str(path)


def argv(ros2: bool, executable: str, **options) -> list[str]:
    base = BaseModel(executable=executable, args=["--verbose"], **options)
    return (ros2_nodes if ros2 else ros1_nodes).command(base)[1:]


def test_ros1_argv_has_name_namespace_remaps_and_params(node_file):
    assert argv(False, node_file, node_name="planner", namespace="/robot1/", remaps={"/scan": "/w/base/scan"},
                params={"rate": 5, "frame": "map"}) == [
        "--verbose", "__name:=planner", "__ns:=/robot1/", "/scan:=/w/base/scan", "_rate:=5", "_frame:=map"]


def test_ros2_argv_puts_them_after_ros_args(node_file):
    assert argv(True, node_file, node_name="planner", namespace="/robot1/", remaps={"/scan": "/w/base/scan"},
                params={"rate": 5.0}) == [
        "--verbose", "--ros-args", "-r", "__node:=planner", "-r", "__ns:=/robot1", "-r", "/scan:=/w/base/scan",
        "-p", "rate:=5.0"]


def test_ros2_argv_without_rules_has_no_ros_args(node_file):
    assert argv(True, node_file) == ["--verbose"]


def test_a_package_executable_needs_a_package_lookup_no_path():
    with pytest.raises(BaseNodeError, match="with a package, the executable is a name in it"):
        ros1_nodes.command(BaseModel(executable="/bin/sh", package="topic_tools"))


@pytest.mark.parametrize("value, text", [
    (5, "5"), (2.5, "2.5"), (True, "true"), ("map", "map"), ("5", "'5'"), ("true", "'true'"),
    ([1, 2], "[1, 2]"), ("", "''"),
])
def test_params_on_the_command_line_read_back_as_given(value, text):
    assert param_value(value) == text


def test_a_private_param_of_either_spelling(node_file):
    assert argv(False, node_file, params={"~gain": 2.5, "_rate": 5})[-2:] == ["_gain:=2.5", "_rate:=5"]
    assert argv(True, node_file, params={"~gain": 2.5})[-2:] == ["-p", "gain:=2.5"]


def test_the_environment(monkeypatch):
    process = BaseProcess(["/bin/true"], log_path=os.devnull, env={"X": "1"})
    assert process.env["X"] == "1" and process.env["PYTHONUNBUFFERED"] == "1"
    assert process.argv == ["/bin/true"] and process.executable == Path("/bin/true")


def test_python_scripts_run_with_this_interpreter(tmp_path: Path):
    script = tmp_path / "node.py"
    script.write_text("#!/usr/bin/env python3\nprint('hi')\n")
    assert python_command(script, ["a"]) == (Path(sys.executable), [str(script), "a"])
    binary = tmp_path / "node"
    binary.write_bytes(b"\x7fELF...")
    assert python_command(binary, ["a"]) == (binary, ["a"])


def test_a_script_that_names_an_interpreter_of_its_own_runs_on_it(tmp_path: Path):
    other = tmp_path / "ws" / "bin" / "python3"
    other.parent.mkdir(parents=True)
    other.write_text("#!/bin/sh\n")
    other.chmod(0o755)
    script = tmp_path / "ws_node.py"
    script.write_text(f"#!{other} -u\nprint('hi')\n")
    assert python_command(script, ["a"]) == (other, ["-u", str(script), "a"])
    assert script_command(str(script)) == (other, ["-u", str(script)]), "not executable: still its interpreter"
    script.write_text(f"#!{tmp_path / 'gone' / 'python3'}\n")  # a stale #! line: this interpreter runs it
    assert python_command(script) == (Path(sys.executable), [str(script)])


def test_a_child_on_another_interpreter_leaves_this_venvs_bootstrap_out(monkeypatch):
    mine = [os.path.join(sys.prefix, "lib"), os.path.join(sys.prefix, "lib", "python3.11", "site-packages",
                                                          "ros_rclpy.libs"), "/opt/vendor/lib"]
    monkeypatch.setenv("_ROS_WHEELS_BOOTSTRAP_COMPLETE", "1")
    monkeypatch.setenv("LD_LIBRARY_PATH", os.pathsep.join(mine))
    other = child_env("/home/me/ws/.venv/bin/python", {"ROBOT_MODE": "sim"})
    assert "_ROS_WHEELS_BOOTSTRAP_COMPLETE" not in other and other["LD_LIBRARY_PATH"] == "/opt/vendor/lib"
    assert other["ROBOT_MODE"] == "sim"
    same = child_env(sys.executable)
    assert same["_ROS_WHEELS_BOOTSTRAP_COMPLETE"] == "1" and same["LD_LIBRARY_PATH"] == os.pathsep.join(mine)


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
