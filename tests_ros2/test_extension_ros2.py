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
