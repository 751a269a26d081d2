"""The master goes away and comes back: declarations fail fast, the session registers again, basenodes are told about."""

from __future__ import annotations

import subprocess

import pytest
from helpers import one_call
from child import Child, ChildError
from peer import Peer
from ros1_fixtures import free_port, master_state, wait_for

SETUP = """
from ipyros import rosNode
from ipyros.node.session import SessionConfig, configure
from std_msgs.msg import String, UInt32
from std_srvs.srv import Empty, EmptyResponse
configure(SessionConfig(master_uri={uri!r}, start_master=False))
got = []
nd = rosNode("phoenix")
nd.new.publish("/phoenix/out", msgType=String).subscribe("/phoenix/in", handler=got.append, msgType=UInt32)
nd.new.service("/phoenix/reset", srvType=Empty, handler=lambda request: EmptyResponse())
nd.params["gain"] = 1.5
nd.create()
w = rosNode("echo_wrapper")
w.baseNode("echo_node").basePackage("ipyros_test_nodes")
w.reuse.subscribe("in", type=String).publish("out", type=String)
w.create()
"""


def start_master(port: int) -> subprocess.Popen:
    uri = f"http://127.0.0.1:{port}/"
    proc = subprocess.Popen(["rosmaster", "--core", "-p", str(port), "-w", "3"], stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    wait_for(lambda: _answers(uri), timeout=20, what="the master to answer")
    return proc


def _answers(uri: str) -> bool:
    try:
        return one_call(uri).getPid("/t")[0] == 1
    except OSError:
        return False


def stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.terminate()
        proc.wait(10)


@pytest.fixture
def own_master(monkeypatch):
    """A master of this test's own (it is killed and started again); peers use it."""
    port = free_port()
    uri = f"http://127.0.0.1:{port}/"
    monkeypatch.setenv("ROS_MASTER_URI", uri)
    masters = [start_master(port)]
    yield uri, port, masters
    for proc in masters:
        stop(proc)


def test_the_master_goes_away_and_comes_back(own_master):
    uri, port, masters = own_master
    with Child() as child:
        child.run(SETUP.format(uri=uri), timeout=60)
        stop(masters[0])
        child.wait_err(f"the ROS master at {uri} does not answer; your nodes keep the connections they have")

        result = child.attempt('nd.new.publish("/phoenix/more", msgType=String)')
        assert isinstance(result, ChildError), result
        assert str(result).startswith(f"MasterError: the ROS master at {uri} does not answer, so opening "
                                      "publisher /phoenix/more on phoenix was not done (nothing changed)"), result
        result = child.attempt('nd.params["other"] = 2')
        assert isinstance(result, ChildError) and "does not answer" in str(result), result
        child.run('nd.new.subscribe("/phoenix/in", handler=lambda m: got.append(m), msgType=UInt32)')  # a swap needs no master
        assert "/phoenix/more" not in child.run("print(nd.model().topics)")

        masters.append(start_master(port))
        child.wait_err(f"the ROS master at {uri} is back (restarted): registered ", timeout=10)
        state = master_state(uri)
        assert state["pub"].get("/phoenix/out") == ["/phoenix"]
        assert "/phoenix" in state["sub"].get("/phoenix/in", [])
        assert state["srv"].get("/phoenix/reset") == ["/phoenix"]
        assert one_call(uri).getParam("/t", "/phoenix/gain") == [1, "Parameter [/phoenix/gain]", 1.5]
        with Peer("publish_rate.py", "/phoenix/in", 50) as peer:  # a new peer finds the session's subscriber
            peer.wait_line("ready")
            wait_for(lambda: int(child.run("print(len(got))")) > 0, timeout=10, what="messages from the new peer")

        advice = child.wait_err("basenode /echo_node of echo_wrapper did not register with the restarted master")
        assert advice.endswith("restart it: echo_wrapper.base.restart()"), advice
        child.run("w.base.restart()", timeout=30)
        wait_for(lambda: "/echo_node" in {n for ns in master_state(uri)["sub"].values() for n in ns}, timeout=15,
                 what="the restarted basenode to register")
