"""End to end: ipyros in a real terminal IPython (prompt_toolkit, under tmux), driven by keys.

What a person at the terminal does and sees, checked on the screen:
load the extension, complete a live topic name with TAB, list topics, subscribe a
handler typed at the prompt, watch its prints arrive above the prompt, pull its source
into the prompt with ``%handler``, edit it with the cursor keys, run it, and see the
new behaviour take over with the prompt intact; then exit, leaving no process behind.

The IPython runs with a home, IPYTHONDIR and ROS_HOME of its own (no user config or
history), on the test master; a peer process publishes the live topic.
"""

from __future__ import annotations

import os
import re
import sys
from pathlib import Path

import pytest
from helpers import pid_alive
from peer import Peer
from ros1_fixtures import master_state, wait_for
from terminal import PROMPT, Terminal, descendants, prompt, prompt_reads, run

TOPIC = "/e2e_turtle/ticks"  # std_msgs/UInt32 0, 1, 2, ... from peers/ticker.py
RATE_HZ = 10
OLD_DEF = 'def on_tick(msg): print("OLD", msg.data)'


@pytest.fixture
def ticks(ros_master):
    """A steady source on TOPIC, like a sensor."""
    with Peer("ticker.py", TOPIC, RATE_HZ) as peer:
        peer.wait_line("ready")
        yield peer


@pytest.fixture
def ipython(ros_master, tmp_path):
    """A terminal IPython in tmux, 160x50, with a fresh home; closed (and checked gone) after."""
    home = tmp_path / "home"
    home.mkdir()
    venv_bin = str(Path(sys.executable).parent)
    env = {**os.environ,
           "HOME": str(home), "IPYTHONDIR": str(home / ".ipython"),
           "ROS_MASTER_URI": ros_master, "ROS_HOME": str(tmp_path / "ros"), "ROS_LOG_DIR": str(tmp_path / "ros" / "log"),
           "PATH": os.pathsep.join([venv_bin, os.environ.get("PATH", "")])}
    for name in ("PYTHONSTARTUP", "COLUMNS", "LINES"):
        env.pop(name, None)
    argv = [str(Path(venv_bin) / "ipython"), "--no-banner", "--colors=NoColor",
            "--TerminalInteractiveShell.simple_prompt=False"]
    with Terminal("ipyros_e2e", argv, env) as term:
        term.wait_for(lambda rows: prompt(rows), timeout=30, what="the first prompt")
        yield term


def numbers(rows: list[str], word: str) -> list[int]:
    """The numbers of the handler's prints ``WORD n`` on the screen, top to bottom.

    Found anywhere in a row: ``print`` writes its pieces one by one, so a print from the
    main thread at the same moment (IPython's, ipyros's) may share a row with one of them.
    """
    return [int(n) for row in rows for n in re.findall(rf"\b{word} (\d+)", row)]


def test_a_session_at_the_terminal(ipython, ticks, ros_master):
    term = ipython

    # Loading prints one line naming the master.
    run(term, "%load_ext ipyros")
    term.wait_for(f"ipyros: ROS master {ros_master} (found running)")

    # TAB completes the live topic in place (a unique match). The graph cache fills in the
    # background within a second of loading: until it has the topic, TAB finds nothing,
    # so press it again until it does.
    term.type("%topics /e2e_tu")

    def completed(rows):
        if (p := prompt(rows)) and p[1] == f"%topics {TOPIC}":
            return True
        term.press("Tab")
        return False

    term.wait_for(completed, timeout=20, what=f"TAB to complete {TOPIC}", interval=0.5)
    term.press("Enter")
    table = term.wait_for(lambda rows: [row for row in rows if TOPIC in row and "│" in row], what="the topics table")
    assert "std_msgs/UInt32" in table[0] and "/ticker_" in table[0]

    # After %pub TOPIC TYPE, TAB inserts the message with every field at its default; Enter sends it.
    term.type("%pub /e2e_template std_msgs/ColorRGBA ")
    term.press("Tab")
    prompt_reads(term, "%pub /e2e_template std_msgs/ColorRGBA {r: 0.0, g: 0.0, b: 0.0, a: 0.0}")
    term.press("Enter")
    term.wait_for("published a std_msgs/ColorRGBA on /e2e_template")

    # %topics alone lists it too, among the others (the table may be longer than the screen).
    run(term, "%topics")
    rows = term.screen(history=True)
    rows = rows[max(i for i, row in enumerate(rows) if (m := PROMPT.match(row)) and m[2] == "%topics"):]
    assert re.fullmatch(r"\d+ live topics at .*", rows[1]), rows[1]
    row = next(row for row in rows if f"│ {TOPIC} " in row)
    assert "std_msgs/UInt32" in row

    # A handler typed at the prompt; its prints land above the prompt.
    run(term, OLD_DEF)
    run(term, "from std_msgs.msg import UInt32")
    run(term, 'nd = rosNode("e2e_node")')
    run(term, f'nd.new.subscribe(topic="{TOPIC}", handler=on_tick, msgType=UInt32)')
    run(term, "nd.create()")
    term.wait_for(lambda rows: len(numbers(rows, "OLD")) >= 3, what="OLD lines from the handler")

    # %handler puts the handler's source in the next prompt...
    term.press("C-l")
    term.line(f"%handler nd {TOPIC}")
    term.wait_for(f"ipyros: edit on_tick and run it: it replaces the handler of e2e_node {TOPIC}")
    prompt_reads(term, OLD_DEF)
    # ... where the cursor keys edit it: OLD -> NEW.
    term.press("End")
    term.press("Left", times=len('OLD", msg.data)'))
    term.press("Delete", times=3)
    term.type("NEW")
    prompt_reads(term, OLD_DEF.replace("OLD", "NEW"))
    term.press("End")
    term.press("Enter")
    swapped = f"ipyros: e2e_node {TOPIC} is now handled by the new on_tick"
    term.wait_for(swapped)
    number = prompt_reads(term, "")
    rows = term.wait_for(lambda rows: len(numbers(rows, "NEW")) >= 3 and rows, what="NEW lines from the edited handler")
    text = "\n".join(rows)
    first_new = next(i for i, row in enumerate(rows) if numbers([row], "NEW"))
    assert not numbers(rows[first_new:], "OLD"), f"the old handler ran after the new one:\n{text}"
    # The swap's notice may land between a print's word and its number ("NEW ipyros: ... on_tick", then "21"
    # rows below): without it, a word and the number after it belong together across rows.
    unbroken = text.replace(swapped, "")
    old, new = ([int(n) for n in re.findall(rf"\b{word}\s+(\d+)", unbroken)] for word in ("OLD", "NEW"))
    if old and new:
        assert new[0] == old[-1] + 1, f"a message was lost in the swap:\n{text}"

    # Prints from ROS threads while a line is being typed: each lands above the prompt, which
    # prompt_toolkit erases and draws again below it (a capture may fall in between, so wait
    # for a screen with both), and stays whole on its own row. Only ROS threads print here.
    term.type("x = 12")
    seen = numbers(term.screen(), "NEW")[-1]
    rows = term.wait_for(lambda rows: numbers(rows, "NEW")[-1] >= seen + 5 and prompt(rows) == (number, "x = 12")
                         and rows, what="5 more NEW lines above the prompt 'x = 12'")
    quiet = rows[next((i + 1 for i, row in enumerate(rows) if swapped in row), 0):]
    stray = [row for row in quiet if re.search(r"(NEW|OLD) \d+", row) and not re.fullmatch(r"(NEW|OLD) \d+", row)]
    assert not stray, f"a print from a ROS thread got mixed into other text: {stray}"

    # Exit: the session ends, nothing it started is left, and its ROS node leaves the master.
    term.press("C-u")
    (ros_node,) = master_state(ros_master)["sub"][TOPIC]  # the IPython's ROS node: the only subscriber
    family = descendants(term.pid)
    term.line("exit")
    term.wait_for(lambda rows: not term.alive() or None, timeout=20, what="IPython to exit")
    left = [pid for pid in {term.pid, *family} if pid_alive(pid)]
    assert not left, f"processes left after exit: {left}"
    wait_for(lambda: not registered(ros_master, ros_node), timeout=10, what=f"{ros_node} to leave the master")


def registered(master_uri: str, node: str) -> list[str]:
    """The topics and services ``node`` is registered for on the master."""
    return [name for kind in master_state(master_uri).values() for name, nodes in kind.items() if node in nodes]
