"""``%graph``: the live graph drawn as the paper draws wrapping, read back from the SVG Graphviz made (its text and
structure, not its pixels) and from the terminal's tree: the wrapping node's frame holds its basenode, the base's
topics are relayed or replaced by a named handler, the wrapping node's own are added, the guard is on its edge."""

from __future__ import annotations

import re
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from shell import error_of, ok
from support import wait_for

TALK = Path(__file__).resolve().parent / "peers" / "talk.py"
SVG = "{http://www.w3.org/2000/svg}"

BUILD = (
    "from geometry_msgs.msg import Twist\n"
    f"gw = rosNode('gw').baseNode({str(TALK)!r}, args=['gw/cmd_vel', 'geometry_msgs/Twist', '20'])\n"
    "def halve(msg):\n    msg.linear.x /= 2\n    gw.write('/gw/cmd_vel', msg)\n"
    "gw.reuse.publish('/gw/cmd_vel', msgType=Twist).publish('/gw/odom', msgType=Twist)\n"
    "gw.new.subscribe('/gw/cmd_vel', halve, msgType=Twist).publish('/gw/status', msgType=Twist)\n"
    "gw.guard('/gw/cmd_vel', limits={'linear.x': (-0.5, 0.5)})\n"
    "gw.create()\n"
)


def shapes(svg: str) -> tuple[dict[str, tuple[float, float, float, float]], dict[str, str]]:
    """Each node's and cluster's box (x0, y0, x1, y1) by its title, and each edge's text by its title."""
    root = ET.fromstring(svg)
    boxes, edges = {}, {}
    for group in root.iter(f"{SVG}g"):
        title = group.find(f"{SVG}title")
        if title is None:
            continue
        name = title.text.replace("&#45;", "-")
        texts = " | ".join(t.text or "" for t in group.iter(f"{SVG}text"))
        if group.get("class") == "edge":
            edges[name] = edges.get(name, "") + " | " + texts
            continue
        points = [tuple(map(float, p.split(","))) for shape in group.iter()
                  if shape.tag in (f"{SVG}polygon", f"{SVG}path") for p in
                  re.findall(r"-?[\d.]+,-?[\d.]+", shape.get("points") or shape.get("d") or "")]
        if points:
            xs, ys = [p[0] for p in points], [p[1] for p in points]
            boxes[name] = (min(xs), min(ys), max(xs), max(ys))
    return boxes, edges


def inside(inner, outer) -> bool:
    return outer[0] <= inner[0] and outer[1] <= inner[1] and inner[2] <= outer[2] and inner[3] <= outer[3]


@pytest.mark.skipif(shutil.which("dot") is None, reason="Graphviz's dot draws the SVG (bash run.sh installs it)")
def test_the_graph_draws_a_wrapping_node_around_its_basenode_with_each_base_topic_and_the_guard(ip, session, capsys,
                                                                                               tmp_path):
    ok(ip, BUILD)
    wait_for(lambda: "/gw/base/gw/cmd_vel" in session.backend.graph_snapshot(2.0).topics, timeout=20,
             what="the basenode publishing on its internal name")
    ok(ip, f"%graph /gw* --save {tmp_path / 'g.svg'}")
    boxes, edges = shapes((tmp_path / "g.svg").read_text())
    ok(ip, "p = %graph /gw*")  # the picture as data: its boxes and wires
    base = next(b.name for b in ip.user_ns["p"].boxes if b.kind == "basenode")
    assert repr(ip.user_ns["p"]).startswith("<the ROS graph drawn: ")
    assert inside(boxes["/gw"], boxes["cluster_/gw"]) and inside(boxes[base], boxes["cluster_/gw"])
    assert "/gw/cmd_vel: replaced by halve" in edges[f"{base}->/gw"] and "/gw/odom: relayed" in edges[f"{base}->/gw"]
    guarded = edges["/gw->topic /gw/cmd_vel"]
    assert "replaced by halve" in guarded and "guard: passing" in guarded
    assert "added" in edges["/gw->topic /gw/status"]
    assert not any("/base/" in name for name in boxes), "internal names are the frame's inner wires, not topics"
    assert not any("ipyros_guard" in name for name in boxes), "the guard is on its edge, not a node"

    capsys.readouterr()
    ok(ip, "%graph /gw*")  # shown once, as the cell's result: in a terminal the tree
    out = capsys.readouterr().out
    assert out.count("/gw (this session, wraps ") == 1, out
    tree = out.splitlines()
    assert f"├─ basenode {base}" in tree
    assert "├─   its /gw/cmd_vel out: replaced by halve" in tree
    assert any(line.startswith("├─ out /gw/cmd_vel (replaced by halve) guard: passing") for line in tree), tree
    ok(ip, "gw.estop()")
    ok(ip, f"%graph /gw* --save {tmp_path / 'stopped.svg'}")
    assert "guard: e-stopped" in shapes((tmp_path / "stopped.svg").read_text())[1]["/gw->topic /gw/cmd_vel"]
    ok(ip, "gw.release()")
    assert "no node /nobody in the graph" in str(error_of(ip, "%graph --node nobody"))
    assert "give a .svg or .png file" in str(error_of(ip, f"%graph --save {tmp_path / 'g.pdf'}"))


def test_the_terminal_tree_fits_80_columns(ip, session, capsys, monkeypatch):
    ok(ip, BUILD)
    monkeypatch.setenv("COLUMNS", "80")
    capsys.readouterr()
    ok(ip, "%graph --types")
    lines = capsys.readouterr().out.splitlines()
    assert any(line.startswith("/gw (this session") for line in lines)
    assert max(len(line) for line in lines) <= 80, [line for line in lines if len(line) > 80]
