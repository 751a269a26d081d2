"""Keeping the work as Python: handler versions, revert, the history file, save and restore.

Everything is typed into a real InteractiveShell (handlers defined in cells, as a person
does), and checked on the live node: messages through ROS, the file's text, the errors.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import warnings
from pathlib import Path

import pytest
from ros1_fixtures import wait_for
from shell import error_of, ok

from ipyros import rosNode
from ipyros.core import journal
from ipyros.core.errors import IpyrosError
from ipyros.dsl import engine_of, restore
from ipyros.files import savefile
from ipyros.ipython.display import renderable

SETUP = '''
from std_msgs.msg import String
heard = []
suffix = "!"
def shout(msg):
    nd.write("/sf/loud", String("v1 " + msg.data))
def beat():
    nd.write("/sf/beat", String("beat"))
nd = rosNode("sf_node")
nd.new.subscribe("/sf/in", handler=shout, msgType=String).publish("/sf/loud", msgType=String)
nd.new.publish("/sf/beat", msgType=String)
nd.timer(0.1, beat)
nd.params["volume"] = 11
nd.create()
probe = rosNode("sf_probe")
probe.new.publish("/sf/in", msgType=String).subscribe("/sf/loud", handler=lambda m: heard.append(m.data), msgType=String)
probe.create()
'''

V2 = '''
def shout(msg):
    nd.write("/sf/loud", String("v2 " + msg.data.upper() + suffix))
nd.new.subscribe("/sf/in", handler=shout, msgType=String)
'''

V3 = '''
def shout(msg):
    nd.write("/sf/loud", String("v3 " + exclaim(msg.data)))
def exclaim(text):
    return text + suffix * 3
nd.new.subscribe("/sf/in", handler=shout, msgType=String)
'''


@pytest.fixture
def sf(ip):
    ok(ip, SETUP)
    yield ip
    ok(ip, "for n in (nd, probe): n.shutdown()")


def answer(ip, text: str, timeout: float = 15.0) -> str:
    """Send ``text`` to /sf/in until an answer to it comes back on /sf/loud (subscriptions take a moment)."""
    heard = ip.user_ns["heard"]

    def got():
        ok(ip, f"probe.write('/sf/in', String({text!r}))")
        return next((h for h in reversed(heard) if text in h or text.upper() in h), None)

    return wait_for(got, timeout, interval=0.1, what=f"an answer to {text!r}")


def test_every_handler_version_is_kept_and_revert_brings_one_back(sf):
    ip = sf
    assert answer(ip, "a").startswith("v1 ")
    ok(ip, V2)
    assert answer(ip, "b") == "v2 B!"
    ok(ip, V3)
    assert answer(ip, "c") == "v3 c!!!"
    versions = ip.user_ns["nd"].versions("/sf/in")
    assert [(v.number, v.name) for v in versions] == [(1, "shout"), (2, "shout"), (3, "shout")]
    assert "v2 " in versions[1].source and versions.current == 3
    ok(ip, "%versions nd /sf/in")

    ok(ip, "%revert nd /sf/in 1")
    assert answer(ip, "d") == "v1 d"
    assert ip.user_ns["nd"].versions("/sf/in").current == 1
    ok(ip, "nd.revert('/sf/in', 3)")
    assert answer(ip, "e") == "v3 e!!!"
    assert len(ip.user_ns["nd"].versions("/sf/in")) == 3  # going back adds no version

    error = error_of(ip, "nd.revert('/sf/in', 7)")
    assert "has versions 1 to 3, not 7" in str(error)


def test_the_history_is_written_to_a_file_of_its_own_as_it_goes(sf):
    ip = sf
    ok(ip, V2)
    session = engine_of(ip.user_ns["nd"]).session
    path = session.journal.path
    assert path is not None and Path(path).parent == Path(os.environ["IPYROS_HISTORY_DIR"])
    lines = [json.loads(line) for line in Path(path).read_text().splitlines()]
    mine = [entry for entry in lines if entry["node"] == "/sf_node"]
    mine = mine[max([i + 1 for i, entry in enumerate(mine) if entry["change"] == "shutdown()"], default=0):]
    shouts = [entry for entry in mine if entry.get("slot") == "topic /sf/in"]
    assert [entry["version"] for entry in shouts] == [1, 2]
    assert "v2 " in shouts[-1]["source"] and shouts[-1]["handler"] == "shout"
    assert any(entry["change"] == "params['volume'] = 11" for entry in mine)
    assert journal.read(path)[-1].change == mine[-1]["change"]  # read back as Change records
    assert f"kept in {path}" in str(renderable(ip.user_ns["nd"].history()).title)


def test_history_files_are_the_users_alone(tmp_path):
    """Handler sources and parameter values (tokens typed at the prompt) are in there."""
    from ipyros.node.session import Change

    made_open = tmp_path / "history"
    made_open.mkdir(mode=0o755)  # as an older ipyros left it
    for directory in (tmp_path / "fresh" / "history", made_open):
        kept = journal.Journal(directory)
        kept.append(Change(0.0, "/n", "params['token'] = 'secret'"))
        kept.close()
        assert directory.stat().st_mode & 0o777 == 0o700
        assert Path(kept.path).stat().st_mode & 0o777 == 0o600


def test_a_saved_file_is_readable_python_that_brings_the_node_back(sf, tmp_path):
    ip = sf
    ok(ip, V2)
    ok(ip, V3)
    ok(ip, "nd.revert('/sf/in', 2)")
    target = tmp_path / "sf.py"
    ok(ip, f"%save_nodes {target} nd")
    text = target.read_text()
    assert savefile.MARKER in text
    assert "from std_msgs.msg import String" in text and "suffix = '!'" in text
    assert 'nd.new.subscribe(\'/sf/in\', handler=shout, msgType=\'std_msgs/String\')' in text
    assert "nd.timer(0.1, beat)" in text and "nd.params['volume'] = 11" in text
    assert "], current=2)" in text and "def exclaim(text)" in text  # v3 needs its helper when brought back
    assert "nd.create()" in text

    ok(ip, "for n in (nd, probe): n.shutdown()")
    ok(ip, "del shout, beat, nd, suffix, exclaim")
    ok(ip, SETUP.split("nd = rosNode")[0] + "probe = rosNode('sf_probe')\n"
       "probe.new.publish('/sf/in', msgType=String).subscribe('/sf/loud', handler=lambda m: heard.append(m.data), "
       "msgType=String)\nprobe.create()")
    ok(ip, f"%load_nodes {target}")
    node = ip.user_ns["nd"]
    assert node.created and node.params["volume"] == 11
    assert answer(ip, "f") == "v2 F!"  # the version that was live when saved
    assert node.versions("/sf/in").current == 2 and len(node.versions("/sf/in")) == 3
    ok(ip, "nd.revert('/sf/in', 3)")
    assert answer(ip, "g") == "v3 g!!!"
    ok(ip, "nd.revert('/sf/in', 1)")
    assert answer(ip, "h") == "v1 h"


def test_save_names_every_handler_without_source_and_writes_nothing(sf, tmp_path):
    ip = sf
    ok(ip, "exec('def made(msg): pass\\ndef ticked(): pass')\n"
       "nd.new.subscribe('/sf/other', handler=made, msgType=String)\nnd.timer(1.0, ticked)")
    target = tmp_path / "no.py"
    error = error_of(ip, f"nd.save({str(target)!r})")
    assert "nothing saved: cannot find the source of handler made for sf_node subscription /sf/other (defined in " \
        "<string>); cannot find the source of handler ticked for sf_node timer ticked" in str(error)
    assert not target.exists()


def test_save_lists_globals_it_cannot_hold(sf, tmp_path):
    ip = sf
    ok(ip, "import threading\nlock = threading.Lock()\n"
       "def guarded(msg):\n    with lock:\n        pass\nnd.new.subscribe('/sf/guarded', handler=guarded, msgType=String)")
    target = tmp_path / "g.py"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ip.user_ns["nd"].save(target, ip.user_ns)
    assert any("lock" in str(w.message) for w in caught if issubclass(w.category, savefile.SaveWarning))
    assert "# Not saved: lock (used by guarded, a lock: not a literal, not importable)" in target.read_text()
    # Through the magic the warning points at the user's line, not into IPython or ipyros.
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ok(ip, f"%save_nodes {tmp_path / 'g2.py'} nd")
    (warning,) = [w for w in caught if issubclass(w.category, savefile.SaveWarning)]
    assert "IPython" not in warning.filename and "ipyros" not in warning.filename, warning.filename


def test_bad_paths_and_files_say_what_is_wrong(sf, tmp_path):
    ip = sf
    node = ip.user_ns["nd"]
    with pytest.raises(IpyrosError, match=r"cannot write /proc/nope\.py"):
        node.save("/proc/nope.py")
    with pytest.raises(IpyrosError, match=r"by the suffix: \.py"):
        node.save(tmp_path / "sf.txt")
    other = tmp_path / "other.py"
    other.write_text("print('hello')\n")
    with pytest.raises(IpyrosError, match="is not a file saved by ipyros"):
        restore(other)
    with pytest.raises(IpyrosError, match="cannot read"):
        restore(tmp_path / "missing.py")


def test_a_file_failing_halfway_leaves_nothing_running(sf, tmp_path):
    ip = sf
    target = tmp_path / "half.py"
    ip.user_ns["nd"].save(target, ip.user_ns)
    ok(ip, "nd.shutdown()")
    # A second node after the first one's create(), which then fails: the first must be stopped again.
    text = target.read_text().replace(
        "    nd.create()\n",
        "    nd.create()\n    late = rosNode('sf_late')\n    late.new.publish('/sf/late', msgType='no_such/Type')\n")
    target.write_text(text)
    session = engine_of(ip.user_ns["nd"]).session
    before = set(session.nodes)
    error = error_of(ip, f"%load_nodes {target}")
    assert "restoring half.py, line" in str(error) and "no_such/Type" in str(error)
    assert "stopped /sf_node again" in str(error)
    assert set(session.nodes) == before


def test_a_saved_file_runs_as_a_script_until_ctrl_c(sf, tmp_path):
    ip = sf
    target = ip.user_ns["nd"].save(tmp_path / "script.py", ip.user_ns)
    ok(ip, "nd.shutdown()")
    proc = subprocess.Popen([sys.executable, str(target)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True, env={**os.environ, "PYTHONUNBUFFERED": "1"}, start_new_session=True)
    try:
        assert answer(ip, "scripted", timeout=30) == "v1 scripted"
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=20)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, out
    assert "ipyros: running /sf_node; Ctrl-C stops it" in out


def test_a_node_of_a_launch_file_is_saved_as_baselaunch(make_node, tmp_path):
    launch = str(Path(__file__).resolve().parents[1] / "launch" / "robot.launch")
    wrapper = make_node("planner_saved")
    wrapper.baseLaunch(launch, "/robot1/planner")
    wrapper.reuse.subscribe("in", type="std_msgs/String")
    text = wrapper.save(tmp_path / "planner.py").read_text()
    assert f"planner_saved.baseLaunch({launch!r}, '/robot1/planner')" in text
    assert "# planner_saved.create()  (it was not running when saved)" in text
    namespace: dict = {}
    (restored,) = restore(tmp_path / "planner.py", namespace)
    assert restored.model() == wrapper.model() and not restored.created
    wrapper.save(tmp_path / "planner.yaml")
    assert rosNode.load(tmp_path / "planner.yaml", trust=True).model() == wrapper.model()
