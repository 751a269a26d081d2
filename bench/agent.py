"""An agent's tool call over HTTP, beside the same magic at the prompt: what the MCP face adds; and ``%graph``.

    python -m bench.agent            # 10,000 topics over 500 nodes; 40 calls of each
    python -m bench.agent --quick    # 2,000 topics; 20 calls

Run with the venv of either ROS (``bash run.sh bench`` runs it in both). A peer advertises the topics (ROS 1: on a
rosmaster of the bench's own; ROS 2: in a DDS domain of its own), an IPython shell loads ipyros and starts
``%mcp start``, and a node of the session publishes a ``UInt32`` at about 500 Hz. Then, one after the other: the
``graph`` tool called through the SDK's own client over HTTP (with the token) beside ``%topics`` at the prompt (its
table rendered to a string), and ``echo`` of 10 messages beside ``%echo TOPIC -n 10``. Each call is timed end to
end; p50 and p99 of each, and the tool's p50 against the magic's (target: at most twice). Then ``%graph`` of the same
graph (the picture folded to the busiest nodes, as it is drawn by default): the terminal's tree beside ``%topics``,
and the SVG Graphviz lays out (target: under 2 s).
"""

from __future__ import annotations

import argparse
import json
import importlib.util
import io
import os
import subprocess
import sys
import tempfile
import threading
import time
from contextlib import redirect_stdout
from pathlib import Path
from typing import Callable, Optional

from bench.figures import Figure, keep, machine, table
from bench.relay import Child, Master, percentile, wait_until

RESULTS = Path(__file__).resolve().parent / "results"
ROOT = Path(__file__).resolve().parents[1]
FAST = "/bench/agent_fast"


#: The agent's side: the SDK's client over HTTP, timing each call (run as a process of its own).
CLIENT = """
import json, sys, time
import anyio, httpx2
from mcp import Client
from mcp.client.streamable_http import streamable_http_client

url, token, topics, repeats, fast = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), sys.argv[5]


async def main():
    async with httpx2.AsyncClient(headers={"Authorization": f"Bearer {token}"}, timeout=60) as http:
        async with Client(streamable_http_client(url, http_client=http)) as client:
            found = await client.call_tool("graph", {})
            if found.is_error or int(found.content[0].text.split()[0]) < topics:
                raise SystemExit(f"the graph tool answered {found.content[0].text[:200]}")
            out = []
            for tool, arguments in (("graph", {}), ("echo", {"topic": fast, "count": 10})):
                await client.call_tool(tool, arguments)  # once untimed, as the magics are
                times = []
                for _ in range(repeats):
                    began = time.perf_counter()
                    result = await client.call_tool(tool, arguments)
                    times.append((time.perf_counter() - began) * 1000)
                    if result.is_error:
                        raise SystemExit(f"{tool}: {result.content[0].text}")
                out.append(times)
            print(json.dumps(out))

anyio.run(main)
"""


def workdir_of(started: object) -> Path:
    return Path(os.environ["IPYROS_MCP_FILE"]).parent


def timed(call: Callable[[], object], repeats: int) -> list[float]:
    """Milliseconds each of ``repeats`` calls took (one untimed first: what is loaded once is not a call's)."""
    call()
    times = []
    for _ in range(repeats):
        began = time.perf_counter()
        call()
        times.append((time.perf_counter() - began) * 1000)
    return times


def main(argv: Optional[list[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.agent", description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="2,000 topics, 20 calls")
    args, _ = parser.parse_known_args(argv)
    topics, repeats = (2000, 20) if args.quick else (10000, 40)
    nodes = max(1, topics // 20)
    ros = "ROS 1" if importlib.util.find_spec("rospy") else "ROS 2"
    with tempfile.TemporaryDirectory(prefix="ipyros-bench-agent-") as tmp:
        workdir = Path(tmp)
        master = None
        if ros == "ROS 1":
            master = Master(workdir)
            env = master.env
            os.environ.update(ROS_MASTER_URI=master.uri, ROS_IP="127.0.0.1")
            argv_ = [sys.executable, str(ROOT / "tests" / "nodes" / "many_topics.py"), "bench_topics", str(topics),
                     "--prefix", "/bench/t", "--nodes", str(nodes)]
        else:
            from bench.relay_ros2 import NODES, environment

            env = environment()
            os.environ.update({k: env[k] for k in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE",
                                                   "AMENT_PREFIX_PATH")})
            os.environ["IPYROS_ROS"] = "2"
            argv_ = [sys.executable, str(NODES / "many_topics.py"), str(topics), "/bench/t", str(nodes)]
        os.environ["IPYROS_MCP_FILE"] = str(workdir / "mcp.json")
        publisher = Child("many_topics", argv_, env, workdir)
        try:
            publisher.expect("ready", 180 + topics / 20)
            figures = run(ros, topics, nodes, repeats)
        finally:
            publisher.stop()
            if master is not None:
                master.stop()
    text = f"Machine: {machine(ros)}.\n\n{table(figures)}\n"
    keep(f"{ros.lower().replace(' ', '')}_agent", figures)
    print(text)
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / f"agent_{ros.lower().replace(' ', '')}.md").write_text(text)
    return 0 if all(f.passed is not False for f in figures) else 1


def run(ros: str, topics: int, nodes: int, repeats: int) -> list[Figure]:
    from IPython.core.interactiveshell import InteractiveShell

    shell = InteractiveShell.instance()
    shell.run_line_magic("load_ext", "ipyros")
    sending = threading.Event()
    try:
        started = shell.run_line_magic("mcp", "start")
        shell.run_cell("from std_msgs.msg import UInt32\nbench_fast = rosNode('bench_agent_fast')\n"
                       f"bench_fast.new.publish({FAST!r}, msgType=UInt32)\nbench_fast.create()")
        fast = shell.user_ns["bench_fast"]
        sending.set()

        def send() -> None:
            count = 0
            while sending.is_set():
                fast.write(FAST, shell.user_ns["UInt32"](data=count))
                count += 1
                time.sleep(0.002)

        sender = threading.Thread(target=send, daemon=True)
        sender.start()
        graph = shell.magics_manager.registry["AgentMagics"].ext.graph
        wait_until(lambda: len(graph.refresh_now().topics_with_prefix("/bench/t")) == topics, 60 + topics / 50,
                   "the session to see every topic", 0.2)

        def magic(line: str) -> Callable[[], object]:
            def call() -> object:
                with redirect_stdout(io.StringIO()):
                    return shell.run_line_magic(*line.split(" ", 1))
            return call

        prompt_graph = timed(magic("topics "), repeats)
        prompt_echo = timed(magic(f"echo {FAST} -n 10"), repeats)
        # %graph of the same graph: the picture (folded to the busiest nodes), as the terminal's tree and as SVG
        from ipyros.core.picture import to_dot, to_text
        from ipyros.tools.drawing import layout

        drawing = magic("graph ")
        drawn = drawing()
        picture_text = timed(lambda: to_text(drawing(), 120), max(5, repeats // 4))
        picture_svg = timed(lambda: layout(to_dot(drawing())), max(5, repeats // 4))
        shown = f"{len(drawn.boxes)} of {nodes} nodes, {len(drawn.wires)} topics drawn"

        # the agent's client in a process of its own, as an agent's is: timed there, end to end
        script = workdir_of(started) / "client.py"
        script.write_text(CLIENT)
        answer = subprocess.run([sys.executable, str(script), started.url, started.token, str(topics), str(repeats),
                                 FAST], capture_output=True, text=True, timeout=600)
        if answer.returncode:
            raise RuntimeError(f"the agent's client failed: {answer.stderr[-2000:]}")
        tool_graph, tool_echo = json.loads(answer.stdout.splitlines()[-1])
    finally:
        sending.clear()
        shell.run_line_magic("mcp", "stop")
        shell.run_line_magic("unload_ext", "ipyros")
        InteractiveShell.clear_instance()
    figures = [Figure(ros, f"%graph of {topics:,} topics over {nodes} nodes ({shown}), the tree, p50",
                      percentile(picture_text, 0.5), "ms", "%topics of the same graph", percentile(prompt_graph, 0.5)),
               Figure(ros, f"%graph of {topics:,} topics over {nodes} nodes ({shown}), an SVG by Graphviz, p50",
                      percentile(picture_svg, 0.5), "ms", most=2000.0)]  # issue 51: under 2 s
    for what, tool, prompt in ((f"graph of {topics:,} topics over {nodes} nodes", tool_graph, prompt_graph),
                               ("10 messages of a 500 Hz topic", tool_echo, prompt_echo)):
        for q in (50, 99):
            figures.append(Figure(ros, f"MCP tool over HTTP, {what}, p{q}", percentile(tool, q / 100), "ms",
                                  "the magic at the prompt", percentile(prompt, q / 100),
                                  most=2.0 if q == 50 else None))
    return figures


if __name__ == "__main__":
    sys.exit(main())
