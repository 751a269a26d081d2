"""%params --dump/--load (as rosparam dump/load) and %param --describe (issue 25)."""

from __future__ import annotations

import yaml
from shell import error_of, ok
from support import wait_for


def test_params_dump_then_load_them_back_and_describe_one(ip, make_node, tmp_path, capsys):
    nd = make_node("pd_node", namespace="/pd")
    nd.params["gain"] = 1.5
    nd.params["label"] = "left"
    nd.create()
    dump = tmp_path / "pd.yaml"
    wait_for(lambda: ok(ip, "%params /pd") and "/pd/pd_node/gain" in capsys.readouterr().out, timeout=20,
             interval=0.3, what="the node's parameters")
    ok(ip, f"%params /pd --dump {dump}")
    assert "written to" in capsys.readouterr().out
    assert yaml.safe_load(dump.read_text()) == {"/pd/pd_node/gain": 1.5, "/pd/pd_node/label": "left"}
    nd.params["gain"] = 9.0
    nd.params["label"] = "right"
    ok(ip, f"%params /pd --load {dump}")
    assert "2 parameters set from" in capsys.readouterr().out
    assert (nd.params["gain"], nd.params["label"]) == (1.5, "left")
    ok(ip, "%param /pd/pd_node/gain --describe")
    described = capsys.readouterr().out
    assert described.startswith("/pd/pd_node/gain: type ") and ("float" in described or "double" in described)
    (tmp_path / "bad.yaml").write_text("[1, 2]")
    assert "expected a mapping of global parameter names" in str(error_of(ip, f"%params --load {tmp_path / 'bad.yaml'}"))


def test_params_watch_shows_a_change_made_from_outside(ip, make_node, peer, capsys):
    nd = make_node("pw_node", namespace="/pw")
    nd.params["gain"] = 1.5
    nd.create()
    wait_for(lambda: ok(ip, "%params /pw") and "/pw/pw_node/gain" in capsys.readouterr().out, timeout=20,
             interval=0.3, what="the node's parameters")
    setter = peer("set_param.py", "/pw/pw_node", "gain", "2.5", 2.0)  # the watch has looked once by then
    ok(ip, "%params /pw --watch -n 1")
    out = capsys.readouterr().out
    assert out.startswith("watching the parameters under /pw for 1 change (Ctrl-C stops)"), out
    assert "/pw/pw_node/gain: 1.5 → 2.5" in out, out
    setter.wait_line("set")
