"""%save_nodes saves the user's nodes that can be saved, says in one line which could not and why, and never
saves ipyros's own tool nodes (issue 25)."""

from __future__ import annotations

from shell import ok


def test_save_nodes_leaves_out_what_has_no_source_and_the_tools(ip, tmp_path, capsys):
    ok(ip, "heard = []\n"
           "def on_words(msg):\n    heard.append(msg.data)\n"
           "good = rosNode('save_good').new.subscribe('/save_good/in', on_words, msgType='std_msgs/String').create()\n"
           "raw = rosNode('save_raw').new.subscribe('/save_raw/in', print, msgType='std_msgs/String').create()")
    ok(ip, "%pub /save_good/in std_msgs/String {data: hi}")  # starts ipyros's own publishing node
    capsys.readouterr()
    ok(ip, f"%save_nodes {tmp_path / 'lab.py'}")
    out = capsys.readouterr().out
    assert "ipyros: not saved: /save_raw: the handler of" in out and "'print'" in out, out
    assert "ipyros: saved /save_good to" in out, out
    text = (tmp_path / "lab.py").read_text()
    assert "rosNode('save_good')" in text and "save_raw" not in text and "rosNode('ipyros_" not in text, text


def test_a_save_warning_is_one_line_not_pythons_warning_with_generated_code(ip, tmp_path, capsys):
    ok(ip, "import threading\nguard = threading.Lock()\n"
           "def guarded(msg):\n    with guard:\n        pass\n"
           "locked = rosNode('save_locked')\n"
           "locked.new.subscribe('/save_locked/in', guarded, msgType='std_msgs/String')")
    capsys.readouterr()
    ok(ip, f"locked.save({str(tmp_path / 'locked.py')!r})")
    err = capsys.readouterr().err
    assert "ipyros: the saved file needs guard defined before it runs" in err, err
    assert "UserWarning" not in err and "run_line_magic" not in err and "warnings.warn" not in err, err
