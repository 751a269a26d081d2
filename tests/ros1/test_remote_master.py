"""A master on the robot's network: this machine's own network address, another machine's, and the address peers
call this session back at; each said in one line (issue 24)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
from ros1_fixtures import free_port

from ipyros.core.errors import MasterError
from ipyros.node.session import Session, SessionConfig
from ipyros.ros1 import master as master_mod
from ipyros.ros1.backend import Ros1

ELSEWHERE = "http://198.51.100.7:{port}/"  # TEST-NET-2: an address no machine here has


def test_a_master_at_this_machines_network_address_is_started_there():
    lan = master_mod.address_towards(ELSEWHERE.format(port=11311))
    if lan is None or lan.startswith("127."):
        pytest.skip("this machine has no network address besides loopback")
    uri = f"http://{lan}:{free_port()}/"
    assert master_mod.is_this_host(uri) and not master_mod.is_this_host(ELSEWHERE.format(port=1))
    env = {k: v for k, v in os.environ.items() if k not in ("ROS_IP", "ROS_HOSTNAME")}
    proc = subprocess.Popen([sys.executable, "-c", "import sys\nfrom ipyros.ros1.master import attach\n"
                             "handle = attach()\nprint(handle.describe(), flush=True)\nsys.stdin.readline()\n"
                             "handle.stop()"], stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env={**env, "ROS_MASTER_URI": uri})
    try:
        said = proc.stdout.readline().strip()
        assert said == (f"ROS master {uri} (started by ipyros, listening on this machine's network ({lan}) for the "
                        "robot's other machines; it stops when this session exits)"), proc.stderr.read()
        assert master_mod.answers(uri, 2.0), "reachable at the network address"
    finally:
        proc.stdin.close()
        assert proc.wait(20) == 0, proc.stderr.read()
    assert not master_mod.answers(uri, 0.5), "stopped with the session"


def test_no_master_on_another_machine_is_said_not_started(monkeypatch):
    remote = ELSEWHERE.format(port=free_port())
    with pytest.raises(MasterError, match=r"on another machine, and ipyros can start one only on this one; start "
                                          r"roscore there, or point ROS_MASTER_URI at this machine"):
        master_mod.attach(remote, start=True, timeout=1.0)
    line = Ros1().connect(Session(SessionConfig(master_uri=remote)), wait=False)
    assert line.startswith(f"no ROS master answers at {remote}, on another machine; start roscore there"), line
    assert "starting one" not in line


def test_the_address_peers_call_back_is_said_for_a_master_elsewhere(monkeypatch):
    remote = ELSEWHERE.format(port=11311)
    monkeypatch.delenv("ROS_IP", raising=False)
    monkeypatch.delenv("ROS_HOSTNAME", raising=False)
    mine = master_mod.address_towards(remote)
    advice = master_mod.callback_advice(remote)
    assert advice is not None and "neither ROS_IP nor ROS_HOSTNAME is set" in advice
    assert advice.endswith(f"export ROS_IP={mine}" if mine else "export ROS_IP=<this machine's address on that "
                                                                 "network>"), advice
    monkeypatch.setenv("ROS_IP", mine or "10.0.0.5")
    assert master_mod.callback_advice(remote) is None, "set: nothing to say"
    assert master_mod.callback_advice("http://localhost:11311/") is None, "a master here: nothing to say"
