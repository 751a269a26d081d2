"""A handler an agent wrote is made a function without running any of its code, and its source stays findable."""

from __future__ import annotations

import inspect

import pytest

from ipyros.mcp.candidate import LONGEST, CandidateError, make_candidate


def test_one_plain_def_becomes_a_function_of_the_namespace_given_its_source_findable():
    namespace = {"gain": 2}
    handler = make_candidate("def h(msg, extra=3):\n    return msg * gain + extra", namespace, "agent_h")
    assert handler(5) == 13 and handler.__name__ == "agent_h" and namespace["agent_h"] is handler
    assert inspect.getsource(handler) == "def agent_h(msg, extra=3):\n    return msg * gain + extra\n"


def test_making_it_runs_nothing_of_the_agents_code():
    ran = []
    namespace = {"note": ran.append}
    make_candidate("def h(msg: note(1)) -> note(2):\n    note(3)\n", namespace)  # annotations left unevaluated
    assert ran == []


@pytest.mark.parametrize("source, said", [
    ("import os\ndef h(m): pass", "one def and nothing else (it holds Import, FunctionDef)"),
    ("x = __import__('os').system('true')", "one def and nothing else (it holds Assign)"),
    ("@staticmethod\ndef h(m): pass", "no decorator"),
    ("def h(m, x=print('hi')): pass", "a default value must be a literal"),
    ("def h(m, *, x=open('/etc/passwd')): pass", "a default value must be a literal"),
    ("def h(:", "not Python"),
    ("class H: pass", "it holds ClassDef"),
    ("", "it holds nothing"),
    (b"def h(m): pass", "text, not bytes"),
    ("def h(m):\n    pass\n" + "#" * LONGEST, "characters; at most"),
])
def test_anything_but_one_plain_def_is_refused_in_one_line(source, said):
    with pytest.raises(CandidateError, match=said.replace("(", r"\(").replace(")", r"\)")):
        make_candidate(source, {})
