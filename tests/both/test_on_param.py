"""``nd.on_param(key, fn)``: a DSL node hears each new value another node or tool sets for its parameter (issue 24)."""

from __future__ import annotations

import pytest
from shell import ok
from support import wait_for

from ipyros.core.errors import NotDeclaredError
from ipyros.dsl import engine_of
from ipyros.files.savefile import SaveWarning


def test_a_parameter_set_from_outside_reaches_the_handler(make_node, peer, notices):
    heard: list = []
    nd = make_node("op_tuned")
    nd.params["gain"] = 1.5
    nd.on_param("gain", heard.append)
    nd.create()
    peer("set_param.py", "/op_tuned", "gain", "2.5").wait_line("set", timeout=30)
    wait_for(lambda: heard == [2.5], timeout=20, what="the new gain at the handler")
    assert nd.params["gain"] == 2.5, "the live value is the one set"
    nd.params["gain"] = 3.0  # set here: not news
    nd.on_param("gain", lambda value: 1 / 0)
    peer("set_param.py", "/op_tuned", "gain", "4.0").wait_line("set", timeout=30)
    wait_for(lambda: any("on_param('gain') handler" in n and "ZeroDivisionError" in n for n in notices),
             timeout=20, what="the handler's crash told")
    assert heard == [2.5], "the value set here called nothing; the replaced handler is not called"
    assert nd.created and nd.params["gain"] == 4.0, "a crashing handler takes nothing down"
    nd.on_param("gain", None)
    nd.shutdown()


def test_on_param_needs_a_value_first(make_node):
    nd = make_node("op_untuned")
    with pytest.raises(NotDeclaredError, match=r"has no parameter 'gain' to watch; give it a value first, "
                                               r"\w+\.params\['gain'\] = \.\.\., then \w+\.on_param"):
        nd.on_param("gain", print)


def test_a_saved_node_keeps_its_on_param_handlers(ip, tmp_path, capsys):
    path = tmp_path / "op_saved.py"
    ok(ip, "tuned = []\n"
           "def on_gain(value):\n    tuned.append(value)\n"
           "saved = rosNode('op_saved')\nsaved.params['gain'] = 1.0\nsaved.on_param('gain', on_gain)\n"
           "other = rosNode('op_unsaved')\nother.params['rate'] = 2\nother.on_param('rate', print)\n"
           "saved.create(); other.create()")
    with pytest.warns(SaveWarning, match=r"the on_param handlers of op_unsaved 'rate' have no source and are not in "
                                         r"the saved file; give them a def"):
        ok(ip, f"from ipyros import save_session\nsave_session({str(path)!r})")
    text = path.read_text()
    assert "def on_gain(value):" in text and "saved.on_param('gain', on_gain)" in text, text
    ok(ip, "saved.shutdown(); other.shutdown()")
    ok(ip, f"%load_nodes {path}")
    loaded = ip.user_ns["rosNode"].running("/op_saved")
    assert engine_of(loaded).param_handlers()["gain"].__name__ == "on_gain"
