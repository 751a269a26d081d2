"""The README's promise on ROS 2, in a real terminal: ``bash run.sh ros2``, the five lines, and the turtle goes round.

As the ROS 1 test (tests/test_readme_terminal.py) does: run under tmux as typed, with a
home of its own, in this run's DDS domain; the five lines are read from the README itself.
On exit, IPython and the turtle must be gone.
"""

from __future__ import annotations

import os
from pathlib import Path

from readme import ROOT, readme_lines, watch_the_turtle_go_round
from ros2_fixtures import wait_for
from terminal import Terminal, descendants, prompt, prompt_reads, run


def test_bash_run_sh_ros2_and_the_five_lines_drive_the_turtle_round(tmp_path):
    home = tmp_path / "home"
    home.mkdir()
    env = {**os.environ, "HOME": str(home), "IPYTHONDIR": str(home / ".ipython"), "ROS_HOME": str(tmp_path / "ros"),
           "ROS_LOG_DIR": str(tmp_path / "ros" / "log"), "IPYROS_HISTORY_DIR": str(tmp_path / "history")}
    for name in ("PYTHONSTARTUP", "COLUMNS", "LINES", "VIRTUAL_ENV", "IPYROS_ROS", "AMENT_PREFIX_PATH"):
        env.pop(name, None)
    with Terminal("ipyros_readme_ros2", ["bash", str(ROOT / "run.sh"), "ros2"], env, width=160, height=50) as term:
        term.wait_for(lambda rows: prompt(rows) == (1, "") and rows, timeout=180, what="the first prompt")
        screen = "\n".join(term.screen(history=True))
        assert "ipyros: ROS 2" in screen and f"ROS_DOMAIN_ID {os.environ['ROS_DOMAIN_ID']}" in screen
        assert "demo robot turtle (running)" in screen and "Drive it in a circle" in screen
        for line in readme_lines():
            run(term, line)
        watch_the_turtle_go_round(term, poses=3)

        # TAB in the terminal: a live topic from the ROS 2 graph, then a message template after %pub TOPIC TYPE
        term.type("%echo /turtle1/po")
        term.wait_for(lambda rows: (p := prompt(rows)) and p[1] == "%echo /turtle1/pose" or term.press("Tab"),
                      timeout=20, what="TAB to complete /turtle1/pose", interval=0.5)
        term.type(" -n 1")
        term.press("Enter")
        term.wait_for(lambda rows: any(row.startswith("orientation:") for row in rows), what="the pose as YAML")
        prompt_reads(term, "")  # the echo is done: the next prompt is up
        term.type("%pub /ipyros_tab std_msgs/msg/ColorRGBA ")
        term.press("Tab")
        prompt_reads(term, "%pub /ipyros_tab std_msgs/msg/ColorRGBA {r: 0.0, g: 0.0, b: 0.0, a: 0.0}")
        term.press("Enter")
        term.wait_for("published a std_msgs/ColorRGBA on /ipyros_tab")

        # %plot in the terminal: the turtle's track as a chart of characters, redrawn until Ctrl-C
        prompt_reads(term, "")
        term.type("p = %plot /turtle1/pose position.x position.y --xy")
        term.press("Enter")
        term.wait_for(lambda rows: any("/turtle1/pose: position.y vs position.x" in row for row in rows)
                      and len([row for row in rows if "│" in row and "*" in row]) >= 3, timeout=20,
                      what="the chart, redrawn with the track's points")
        term.press("C-c")
        term.wait_for(lambda rows: any("ipyros: plotted" in row for row in rows), timeout=10, what="Ctrl-C to stop it")
        run(term, 'print("POINTS", len(p.data["t"]) > 3, p.running)')
        term.wait_for("POINTS True False")
        family = descendants(term.pid)
        assert family, "the turtle runs below IPython"
        term.line("exit")
        term.wait_for(lambda rows: not term.alive() or None, timeout=30, what="IPython to exit")
        wait_for(lambda: not [pid for pid in {term.pid, *family} if Path(f"/proc/{pid}").exists()
                              and Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"],
                 timeout=15, what="IPython's processes to end")
