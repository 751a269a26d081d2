"""A basenode gets the environment it is given, ``baseNode(..., env={...})`` (issue 24)."""

from __future__ import annotations

from pathlib import Path

import pytest
from support import wait_for

from ipyros.core.errors import DeclarationError

ENV_NODE = Path(__file__).parent / "peers" / "env_node.py"


def test_env_reaches_the_basenode_and_a_wrong_one_is_refused(make_node):
    w = make_node("env_wrap")
    with pytest.raises(DeclarationError, match=r"baseNode\(env=.*\): give a dict of variable names and string values"):
        w.baseNode(str(ENV_NODE), env={"ROBOT_MODE": 3})
    w.baseNode(str(ENV_NODE), namespace="env_robot", env={"ROBOT_MODE": "sim"})
    w.create()
    wait_for(lambda: any("env_node ready" in line for line in w.base.tail()), what="the basenode")
    assert any(line == "mode sim" for line in w.base.tail()), w.base.tail()
    assert w.model().base.env == {"ROBOT_MODE": "sim"}
    w.shutdown()
