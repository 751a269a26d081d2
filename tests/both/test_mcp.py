"""``%mcp``: an AI agent in the session through the Model Context Protocol, driven by the SDK's own client (in memory,
and over HTTP with and without the token): it reads the graph, types, messages and the session's nodes; rehearses a
candidate handler; proposes it, and nothing changes until the person approves at the prompt; publishes only on the
names allowed, in any spelling, and through the guard; e-stops always."""

from __future__ import annotations

import json
import os
import socket
import sys
import threading
import time
import urllib.error
import urllib.request
from pathlib import Path

import anyio
import pytest
from shell import error_of, ok
from support import wait_for

pytest.importorskip("mcp")

from mcp import Client  # noqa: E402 - after the skip

from ipyros.mcp import desk as desk_module  # noqa: E402

BUILD = (
    "from geometry_msgs.msg import Twist\n"
    "def drive(msg):\n    mc.write('/mc/cmd_vel', msg)\n"
    "mc = rosNode('mc')\n"
    "mc.new.subscribe('/mc/in', drive, msgType=Twist).publish('/mc/cmd_vel', msgType=Twist)\n"
    "mc.guard('/mc/cmd_vel', limits={'linear.x': (-0.5, 0.5)})\n"
    "from std_srvs.srv import SetBool\n"
    "answer = getattr(SetBool, '_response_class', None) or SetBool.Response  # ROS 1, ROS 2\n"
    "mc.new.service('/mc/ping', SetBool, handler=lambda request: answer(success=request.data, message='pong'))\n"
    "mc.create()\n"
)


def call(server, tool: str, **arguments):
    """One tool call through the SDK's in-memory client: (text, structured data, is_error)."""
    async def ask():
        async with Client(server) as client:
            return await client.call_tool(tool, arguments)

    result = anyio.run(ask)
    return result.content[0].text, result.structured_content, result.is_error


def agent(ip):
    return ip.magics_manager.registry["AgentMagics"]


def twist_xs(listener) -> list[float]:
    return [float(line.split()[1]) for line in list(listener.lines) if line.startswith("twist ")]


def test_an_agent_reads_rehearses_and_changes_only_what_the_person_approves(ip, session, peer, capsys, monkeypatch,
                                                                             tmp_path):
    motors = peer("listen_twist.py", "/mc/cmd_vel", "--name=mc_motors")
    motors.wait_line("ready")
    ok(ip, BUILD)
    ok(ip, "started = %mcp start --allow-publish mc/cmd_vel --allow-swap mc --allow-call /mw/reset mc/ping")
    started = ip.user_ns["started"]
    assert started.url.startswith("http://127.0.0.1:") and len(started.token) > 30
    assert started.token not in repr(started)  # shown once, not in every repr
    server = agent(ip).server.mcp
    mc = ip.user_ns["mc"]
    feeding = threading.Event()
    feeding.set()

    def feed():  # the input the handler turns into commands, 20 Hz, numbered in linear.y
        from geometry_msgs.msg import Twist
        number = 0
        while feeding.is_set():
            number += 1
            msg = Twist()
            msg.linear.x, msg.linear.y = 0.2, float(number)
            ip.user_ns["feeder"].write("/mc/in", msg)
            time.sleep(0.05)

    ok(ip, "feeder = rosNode('mc_feeder')\nfeeder.new.publish('/mc/in', msgType=Twist)\nfeeder.create()")
    thread = threading.Thread(target=feed, daemon=True)
    thread.start()
    try:
        # reading
        text, data, error = call(server, "graph", pattern="/mc/*", rates=True, parameters=True)
        assert not error and {t["name"]: t["type"] for t in data["topics"]}["/mc/cmd_vel"] == "geometry_msgs/Twist"
        assert 10 < {t["name"]: t["hz"] for t in data["topics"]}["/mc/in"] < 30, data["topics"]
        assert isinstance(data["parameters"], dict)
        text, data, error = call(server, "interface", type="geometry_msgs/Twist")
        assert not error and "Vector3 linear" in text and "float64 x" in text
        text, data, error = call(server, "echo", topic="/mc/in.linear.x", count=2)
        assert not error and data["messages"] == [0.2, 0.2], text
        text, data, error = call(server, "nodes")
        node = next(n for n in data["nodes"] if n["name"] == "/mc")
        assert node["handlers"][0]["handler"] == "drive" and "def drive" in node["handlers"][0]["source"]
        assert node["guards"][0]["state"] == "passing" and node["may_propose"]
        wait_for(lambda: 0.2 in twist_xs(motors), what="the motors hear the handler's commands")

        # rehearsing: nothing is swapped or sent
        double = "def twice(msg):\n    msg.linear.x *= 2\n    mc.write('/mc/cmd_vel', msg)\n"
        text, data, error = call(server, "rehearse", node="mc", topic="/mc/in", source=double, last=2)
        assert not error and data["messages"] == 2 and data["differing"] == 2, data
        assert mc.handler("/mc/in").__name__ == "drive"
        text, data, error = call(server, "rehearse", node="mc", topic="/mc/in", source="import os\ndef h(m): pass")
        assert error and "one def and nothing else" in text
        flood = "def flood(msg):\n    for _ in range(100000):\n        mc.write('/mc/cmd_vel', msg)\n"
        text, data, error = call(server, "rehearse", node="mc", topic="/mc/in", source=flood, last=1)
        assert not error and "wrote 100,000 messages for one input: the first 1,000 kept" in text
        bag = tmp_path / ("in.bag" if session.backend.name == "ROS 1" else "in")  # ROS 2: a rosbag2 folder
        ok(ip, "from ipyros.tools.record import bag_module\n"
               f"writer = bag_module().BagWriter(__import__('pathlib').Path({str(bag)!r}))\n"
               "for i in range(1, 11):\n    writer.write('/mc/in', Twist(linear=type(Twist().linear)(x=i / 10)))\n"
               "writer.close()")
        text, data, error = call(server, "bag_info", path=str(bag))
        assert not error and [(t["topic"], t["count"]) for t in data["topics"]] == [("/mc/in", 10)], data
        assert data["topics"][0]["type"].replace("/msg/", "/") == "geometry_msgs/Twist"  # ROS 2 bags: pkg/msg/Type
        text, data, error = call(server, "rehearse", node="mc", topic="/mc/in", source=double, bag=str(bag))
        assert not error and (data["messages"], data["differing"]) == (10, 10), data
        # what the guard would do: the live handler's 0.6 ... 1.0 clamped, the candidate's 0.6 ... 2.0 too
        assert data["guarded"]["live"]["/mc/cmd_vel"] == {"passed": 5, "clamped": 5}, data["guarded"]
        assert data["guarded"]["candidate"]["/mc/cmd_vel"] == {"passed": 2, "clamped": 8}, data["guarded"]
        monkeypatch.setattr(desk_module, "REHEARSAL_SECONDS", 1.0)
        spin = "def spin(msg):\n    while True:\n        pass\n"
        text, data, error = call(server, "rehearse", node="mc", topic="/mc/in", source=spin, last=1)
        assert error and "stopped after 1 s" in text
        text, data, error = call(server, "rehearse", node="mc", topic="/mc/in", source="def bad(msg):\n"
                                 "    raise SystemExit(3)\n", last=1)
        assert not error and "SystemExit: 3" in text

        # proposing: nothing changes until the person approves
        capsys.readouterr()
        text, data, error = call(server, "propose", node="/mc", topic="/mc/in", source=double)
        assert not error and data["request"] == 1 and data["state"] == "pending", text
        time.sleep(0.3)  # a window for what must not happen: the handler unchanged, no doubled command heard
        assert mc.handler("/mc/in").__name__ == "drive" and 0.4 not in twist_xs(motors)
        told = capsys.readouterr().err
        assert "the agent asks (#1): make this the handler of /mc/in on /mc" in told
        assert "+    msg.linear.x *= 2" in told
        assert "%mcp approve 1" in told
        ok(ip, "%mcp approve 1")
        assert mc.handler("/mc/in").__name__ == "agent_in"
        wait_for(lambda: twist_xs(motors).count(0.4) >= 5, what="the approved handler's commands")
        heard = [line.split() for line in list(motors.lines) if line.startswith("twist ")]
        swapped = next(i for i, words in enumerate(heard) if float(words[1]) == 0.4)
        around = [float(words[2]) for words in heard[max(0, swapped - 20):]]
        assert around == [around[0] + i for i in range(len(around))], "no message lost across the swap"
        assert [c.by for c in session.history if c.node.strip("/") == "mc"][-1] == "the agent, request #1"
        assert "(by the agent, request #1)" in str(mc.history())
        assert "cannot be answered: it was approved already" in str(error_of(ip, "%mcp approve 1"))
        text, data, error = call(server, "history", node="mc")
        assert data["changes"][-1]["by"] == "the agent, request #1" and data["requests"][0]["state"] == "approved"
        text, data, error = call(server, "request", number=1)
        assert data["state"] == "approved" and "agent_in" in data["answer"]

        # reverting: asked, then made
        text, data, error = call(server, "revert", node="mc", topic="/mc/in", version=1)
        assert not error and data["number"] == 2
        ok(ip, "%mcp deny 2")
        assert mc.handler("/mc/in").__name__ == "agent_in"
        text, data, error = call(server, "revert", node="mc", topic="/mc/in", version=1)
        ok(ip, f"%mcp approve {data['number']}")
        assert mc.handler("/mc/in").__name__ == "drive"
    finally:
        feeding.clear()
        thread.join(5)

    # publishing: only on the allowed name, whatever its spelling; through the guard
    for spelling in ("/mc/in", "mc/in", "/mc/in/", "//mc//in", "/mc/./in", "/other"):
        text, data, error = call(server, "publish", topic=spelling, message={"linear": {"x": 3.0}})
        assert error and "the agent may not publish on /" in text, (spelling, text)
    for spelling in ("~cmd_vel", "/mc/../in", 5):
        text, data, error = call(server, "publish", topic=spelling, message={})
        assert error, spelling
    text, data, error = call(server, "publish", topic="/mc/cmd_vel/", message={"linear": {"x": 3.0}})
    assert not error and "through the guard of mc" in data["what"], text
    before = len(twist_xs(motors))
    ok(ip, f"%mcp approve {data['number']}")
    wait_for(lambda: 0.5 in twist_xs(motors)[before:], what="the published command, clamped by the guard")
    assert 3.0 not in twist_xs(motors)

    # a call of an allowed service, once approved
    text, data, error = call(server, "call", service="/mc/ping", request={"data": True})
    assert not error and data["state"] == "pending", text
    ok(ip, f"%mcp approve {data['number']}")
    text, data, error = call(server, "request", number=data["number"])
    assert data["state"] == "approved" and "called /mc/ping (std_srvs/SetBool)" in data["answer"], data
    assert "'success': True, 'message': 'pong'" in data["answer"]

    # the e-stop: always allowed, released only at the prompt
    text, data, error = call(server, "estop")
    assert not error and data["estopped"] == ["/mc/cmd_vel (/mc)"]
    text, data, error = call(server, "history")
    assert any("the agent e-stopped /mc/cmd_vel" in n["notice"] for n in data["notices"]), data["notices"]
    assert "e-stopped" in str(mc.status())
    mc.release()

    # a service relayed to a basenode whose output is guarded: refused, though allowed by name
    base = Path(__file__).resolve().parent / "peers" / "listen_twist.py"
    ok(ip, f"mw = rosNode('mw')\nmw.baseNode({str(base)!r}, args=['/mw/heard', '--name=mw_base'])\n"
           "mw.reuse.service('/mw/reset', type='std_srvs/Empty').publish('/mw/cmd_vel', msgType=Twist)\n"
           "mw.guard('/mw/cmd_vel', limits={'linear.x': (-0.5, 0.5)})\nmw.create()")
    text, data, error = call(server, "call", service="mw//reset/")
    assert error and "/mw/reset is relayed to the basenode" in text and "/mw/cmd_vel are guarded" in text, text
    # a rehearsal runs the agent's code: only on a node the person allowed
    text, data, error = call(server, "rehearse", node="mw", topic="/mw/cmd_vel", source="def h(msg): pass", last=1)
    assert error and "the agent may not change /mw's handlers" in text, text
    ok(ip, "%mcp stop")
    assert agent(ip).server is None


def test_the_server_listens_on_loopback_behind_its_token_and_leaves_nothing_listening(ip, session, tmp_path,
                                                                                      monkeypatch):
    monkeypatch.setenv("IPYROS_MCP_FILE", str(tmp_path / "mcp.json"))
    ok(ip, "s = %mcp start")
    started = ip.user_ns["s"]
    kept = json.loads((tmp_path / "mcp.json").read_text())
    assert kept["token"] == started.token and (tmp_path / "mcp.json").stat().st_mode & 0o777 == 0o600
    listing = json.dumps({"jsonrpc": "2.0", "id": 1, "method": "tools/list"}).encode()

    def post(body: bytes, **headers: str) -> tuple[int, str]:
        request = urllib.request.Request(started.url, data=body, headers={
            "Content-Type": "application/json", "Accept": "application/json, text/event-stream", **headers})
        try:
            with urllib.request.urlopen(request, timeout=10) as answer:
                return answer.status, answer.read().decode()
        except urllib.error.HTTPError as error:
            return error.code, error.read().decode()

    assert post(listing)[0] == 401
    assert post(listing, Authorization="Bearer wrong")[0] == 401
    assert post(listing, Authorization=f"Bearer {started.token}", Host="evil.example:80")[0] == 421
    assert post(b"x" * 400_000, Authorization=f"Bearer {started.token}")[0] == 413
    status, said = post(b'{"jsonrpc": "2.0", "id": 1, "method": ', Authorization=f"Bearer {started.token}")
    assert status == 400 and "Parse error" in said, (status, said)

    async def over_http():
        import httpx2
        from mcp.client.streamable_http import streamable_http_client

        async with httpx2.AsyncClient(headers={"Authorization": f"Bearer {started.token}"}) as http:
            async with Client(streamable_http_client(started.url, http_client=http)) as client:
                return await client.call_tool("graph", {"pattern": "/rosout"})

    result = anyio.run(over_http)
    assert not result.is_error and "topics" in result.structured_content

    async def over_the_bridge():  # python -m ipyros.mcp, as a client that starts a command runs it
        from mcp import StdioServerParameters

        bridge = StdioServerParameters(command=sys.executable, args=["-m", "ipyros.mcp"],
                                       env={**os.environ, "IPYROS_MCP_FILE": str(tmp_path / "mcp.json")})
        async with Client(bridge) as client:
            return (await client.call_tool("graph", {"pattern": "/rosout"}),
                    await client.call_tool("estop", {}))

    result, refused = anyio.run(over_the_bridge)
    assert not result.is_error and "topics" in result.structured_content
    assert refused.is_error and "no running node of the session has a guard" in refused.content[0].text
    port = int(started.url.rsplit(":", 1)[1].split("/")[0])
    ok(ip, "%mcp stop")
    assert not (tmp_path / "mcp.json").exists()
    with pytest.raises(OSError):
        socket.create_connection(("127.0.0.1", port), timeout=2).close()
    assert "no agent's server runs" in str(error_of(ip, "%mcp approve 3"))


def test_an_agent_reads_the_demo_turtle(ip, session):
    """The graph, a type, a message path of the turtle's pose, and the turtle's node, read by an agent."""
    from ipyros.tools.robot import demo_robot, stop_demo_robot

    demo_robot("turtle")
    try:
        ok(ip, "%mcp start")
        server = agent(ip).server.mcp
        wait_for(lambda: any(t["name"] == "/turtle1/pose"
                             for t in call(server, "graph", pattern="/turtle1*")[1]["topics"]),
                 timeout=20, interval=0.2, what="the turtle's pose in the agent's graph")
        text, data, error = call(server, "graph", pattern="/turtle1*")
        pose = next(t for t in data["topics"] if t["name"] == "/turtle1/pose")
        assert pose["publishers"] and "/turtle1/cmd_vel" in {t["name"] for t in data["topics"]}
        text, data, error = call(server, "interface", type=pose["type"])
        assert not error and "position" in text
        text, data, error = call(server, "echo", topic="/turtle1/pose.position", count=1)
        assert not error and set(data["messages"][0]) == {"x", "y", "z"}, data
        ok(ip, "%mcp stop")
    finally:
        stop_demo_robot()
