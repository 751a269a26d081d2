"""%load_ext ipyros on ROS 2: one line naming the ROS, and the DSL at the prompt with its one-line errors."""

from __future__ import annotations

import os

import pytest
from IPython.core.interactiveshell import InteractiveShell
from traitlets.config import Config


@pytest.fixture
def ip(ros2_session, capsys):
    config = Config()
    config.HistoryManager.hist_file = ":memory:"
    config.InteractiveShell.colors = "nocolor"
    InteractiveShell.clear_instance()
    shell = InteractiveShell.instance(config=config)
    yield shell
    if "ipyros" in shell.extension_manager.loaded:
        shell.run_line_magic("unload_ext", "ipyros")
    InteractiveShell.clear_instance()


def test_load_line_names_ros2_and_the_dsl_works_at_the_prompt(ip, capsys):
    ip.run_line_magic("load_ext", "ipyros")
    line = capsys.readouterr().out.strip()
    assert line.startswith("ipyros: ROS 2 Kilted (rclpy 9."), line
    assert f"ROS_DOMAIN_ID {os.environ['ROS_DOMAIN_ID']}, rmw_fastrtps_cpp, discovery localhost" in line
    assert "the DSL and wrapping run here" in line
    result = ip.run_cell("from std_msgs.msg import String\n"
                         "nd = rosNode('prompt_node', namespace='/r2').new.publish('out', msgType=String).create()\n"
                         "nd.write('out', String(data='a'))")
    assert result.success, result.error_in_exec
    ip.run_cell("%status nd")
    assert "status of /r2/prompt_node" in capsys.readouterr().out
    result = ip.run_cell("nd.timer(0, print)")
    assert not result.success
    shown = capsys.readouterr()
    assert "DeclarationError: timer period must be a number of seconds" in shown.out + shown.err
    assert "Traceback" not in shown.out + shown.err, "one line, no traceback"
    ip.run_cell("nd.shutdown()")


def test_wrap_magic_and_its_completion_from_the_ament_index(ip, capsys, tmp_path, monkeypatch):
    import shutil
    import sys
    from pathlib import Path

    from IPython.core.completer import provisionalcompleter

    prefix = tmp_path / "install"  # a package as colcon installs one
    (prefix / "share" / "ament_index" / "resource_index" / "packages").mkdir(parents=True)
    (prefix / "share" / "ament_index" / "resource_index" / "packages" / "echo_pkg").touch()
    (prefix / "lib" / "echo_pkg").mkdir(parents=True)
    node = prefix / "lib" / "echo_pkg" / "echo_node"
    node.write_text(f"#!{sys.executable}\n" + (Path(__file__).parent / "peers" / "echo_node.py").read_text())
    node.chmod(0o755)
    monkeypatch.setenv("AMENT_PREFIX_PATH", os.pathsep.join([str(prefix), sys.prefix]))

    ip.run_line_magic("load_ext", "ipyros")
    with provisionalcompleter():
        assert [c.text for c in ip.Completer.completions("%wrap echo_p", 12)] == ["echo_pkg"]
        assert [c.text for c in ip.Completer.completions("%wrap echo_pkg ec", 17)] == ["echo_node"]
    capsys.readouterr()
    result = ip.run_cell("%wrap echo_pkg echo_node --ns robot8 --as ew")
    assert result.success, result.error_in_exec
    out = capsys.readouterr().out
    assert "rosNode /robot8/ew (running) wrapping echo_pkg/echo_node" in out and "bound to ew" in out
    assert "/robot8/check" in out and "/robot8/out" in out
    ip.run_cell("ew.shutdown()")
    shutil.rmtree(prefix)
