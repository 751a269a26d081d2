"""The live graph as a picture, drawn as the paper draws wrapping: a wrapping node's frame around its basenode, the
base's topics relayed, replaced by a handler or added, guards on their edges; large graphs cut down and said so."""

from __future__ import annotations

import dataclasses
import re

from ipyros.core.graph import GraphSnapshot, frozen
from ipyros.core.model import BaseModel, NodeModel, TopicModel
from ipyros.core.picture import Drawn, picture, to_dot, to_text

WRAPPER = dataclasses.replace(
    NodeModel(name="w", namespace="/"), base=BaseModel(executable="move_base", package="ipyros_demo"),
    topics=[TopicModel("cmd_vel", "/cmd_vel", "publish", "geometry_msgs/Twist", "reuse"),
            TopicModel("cmd_vel", "/cmd_vel", "subscribe", "geometry_msgs/Twist", "new", handler="slow"),
            TopicModel("odom", "/odom", "publish", "nav_msgs/Odometry", "reuse"),
            TopicModel("scan", "/scan", "subscribe", "sensor_msgs/LaserScan", "reuse"),
            TopicModel("status", "/w/status", "publish", "std_msgs/String", "new")])
SNAP = GraphSnapshot(
    topics=frozen({"/cmd_vel": "geometry_msgs/Twist", "/odom": "nav_msgs/Odometry", "/scan": "sensor_msgs/LaserScan",
                   "/w/base/cmd_vel": "geometry_msgs/Twist", "/w/base/odom": "nav_msgs/Odometry",
                   "/w/base/scan": "sensor_msgs/LaserScan", "/w/status": "std_msgs/String",
                   "/rosout": "rosgraph_msgs/Log"}),
    publishers=frozen({"/cmd_vel": ("/w", "/ipyros_guard_12_1"), "/odom": ("/w",), "/w/base/cmd_vel": ("/move_base",),
                       "/w/base/odom": ("/move_base",), "/scan": ("/laser",), "/w/base/scan": ("/w",),
                       "/w/status": ("/w",), "/rosout": ("/w", "/laser")}),
    subscribers=frozen({"/cmd_vel": ("/motors",), "/odom": ("/viewer",), "/w/base/cmd_vel": ("/w",),
                        "/w/base/odom": ("/w",), "/scan": ("/w",), "/w/base/scan": ("/move_base",)}),
    nodes=("/ipyros_guard_12_1", "/laser", "/motors", "/move_base", "/viewer", "/w"), master_up=True)
OURS = {"/w": Drawn(WRAPPER, {"/cmd_vel": "passing, 3 clamped"})}


def test_a_wrapping_node_frames_its_basenode_and_says_what_happens_to_each_base_topic():
    drawn = picture(SNAP, OURS, unseen={"/ipyros_guard_12_1"})
    kinds = {b.name: (b.kind, b.frame) for b in drawn.boxes}
    assert kinds["/w"] == ("wrapping", "/w") and kinds["/move_base"] == ("basenode", "/w")
    assert kinds["/laser"] == ("node", "") and "/ipyros_guard_12_1" not in kinds
    assert {(i.source, i.target, i.topic, i.role) for i in drawn.inner} == {
        ("/move_base", "/w", "/cmd_vel", "replaced by slow"), ("/move_base", "/w", "/odom", "relayed"),
        ("/w", "/move_base", "/scan", "relayed")}
    wires = {w.topic: w for w in drawn.wires}
    assert set(wires) == {"/cmd_vel", "/odom", "/scan", "/w/status"}  # internal names are the frame's inner wires
    assert (wires["/cmd_vel"].role, wires["/cmd_vel"].guard) == ("replaced by slow", "passing, 3 clamped")
    assert wires["/cmd_vel"].publishers == ("/w",)  # the guard's own process is the guard on the edge
    assert wires["/w/status"].role == "added" and wires["/odom"].subscribers == ("/viewer",)


def test_graphviz_gets_a_frame_a_wrapping_node_named_edges_and_the_guard_coloured_by_its_state():
    drawn = picture(SNAP, OURS, unseen={"/ipyros_guard_12_1"}, types=True)
    dot = to_dot(dataclasses.replace(drawn, rates={"/odom": "50.0 Hz"}))
    frame = dot[dot.index('subgraph "cluster_/w"'):dot.index("  }")]
    assert '"/move_base" [label="/move_base\\n(basenode)"' in frame and '"/w" [label=' in frame
    assert '"/move_base" -> "/w" [label="/cmd_vel: replaced by slow"' in dot
    assert '"/w" -> "/move_base" [label="/scan: relayed"' in dot
    assert re.search(r'"/w" -> "topic /cmd_vel" \[label="replaced by slow", headlabel="guard: passing, 3 clamped", '
                     r'color="#15803d"', dot)
    assert '"/laser" -> "topic /scan";' in dot  # the role is said on the wrapping node's edge, not the laser's
    assert '"topic /odom" [label="/odom\\nnav_msgs/Odometry\\n50.0 Hz"' in dot
    assert "rosout" not in dot and "ipyros_guard" not in dot
    stopped = to_dot(picture(SNAP, {"/w": Drawn(WRAPPER, {"/cmd_vel": "e-stopped"})}))
    assert 'headlabel="guard: e-stopped", color="#b91c1c"' in stopped
    assert ", size=" not in dot and 'newrank=true, size="10,12"];' in to_dot(drawn, (10, 12))  # a cell's width


def test_the_text_is_a_tree_by_node_that_fits_the_width():
    drawn = picture(SNAP, OURS, unseen={"/ipyros_guard_12_1"}, types=True)
    text = to_text(drawn, 80)
    lines = text.splitlines()
    assert lines[0] == "/w (this session, wraps ipyros_demo/move_base)"
    assert "├─ basenode /move_base" in lines and "├─   its /cmd_vel out: replaced by slow" in lines
    assert any(line.startswith("├─ out /cmd_vel [geometry_msgs/Twist] (replaced by slow) guard: passing")
               for line in lines)
    assert "└─ out /scan [sensor_msgs/LaserScan] → /w" in lines  # the laser's own lines say no role
    for width in (40, 80, 200):
        assert max(len(line) for line in to_text(drawn, width).splitlines()) <= width


def test_a_pattern_or_a_node_and_its_neighbours_cut_the_graph_down_and_say_what_is_left_out():
    drawn = picture(SNAP, OURS, pattern="/odom")
    assert {w.topic for w in drawn.wires} == {"/odom"}
    assert {b.name for b in drawn.boxes} == {"/w", "/move_base", "/viewer"}  # a frame is drawn whole
    assert drawn.left_out.startswith("3 topics and ") and "outside '/odom'" in drawn.left_out
    near = picture(SNAP, OURS, focus="/laser", depth=1)
    assert {b.name for b in near.boxes} == {"/laser", "/w", "/move_base"}
    assert {w.topic for w in near.wires} == {"/scan", "/cmd_vel", "/odom", "/w/status"}
    alone = picture(SNAP, OURS, focus="/viewer", depth=0)
    assert [b.name for b in alone.boxes] == ["/viewer"]


def test_a_large_graph_draws_the_sessions_nodes_and_the_busiest_and_counts_the_rest():
    topics = {f"/t{i}": "std_msgs/String" for i in range(400)}
    snap = GraphSnapshot(topics=frozen(topics), publishers=frozen({t: (f"/n{i % 200}",) for i, t in enumerate(topics)}),
                         subscribers=frozen({t: ("/sink",) for t in topics}),
                         nodes=tuple(sorted({f"/n{i}" for i in range(200)} | {"/sink"})), master_up=True)
    drawn = picture(snap, {}, most=20)
    assert len(drawn.boxes) == 20 and "/sink" in {b.name for b in drawn.boxes}
    assert drawn.left_out == ("181 of 201 nodes not drawn (the session's and the busiest are): give a pattern, "
                              "or --node NAME --depth K")
    assert all(w.publishers or w.subscribers for w in drawn.wires)
    assert repr(drawn) == "<the ROS graph drawn: 20 nodes, 400 topics>"


def test_a_role_is_said_on_the_wrapping_nodes_edges_only_not_on_another_session_nodes():
    viewer = NodeModel(name="viewer", namespace="/", topics=[
        TopicModel("odom", "/odom", "subscribe", "nav_msgs/Odometry", "new", handler="show"),
        TopicModel("scan", "/scan", "publish", "sensor_msgs/LaserScan", "new")])  # a second sender of /scan
    for ours in ({**OURS, "/viewer": Drawn(viewer)}, {"/viewer": Drawn(viewer), **OURS}):  # whichever comes first
        assert '"topic /scan" -> "/w" [label="relayed"];' in to_dot(picture(SNAP, ours))
    drawn = picture(SNAP, {**OURS, "/viewer": Drawn(viewer)}, unseen={"/ipyros_guard_12_1"})
    dot = to_dot(drawn)
    assert '"/w" -> "topic /odom" [label="relayed"];' in dot and '"topic /odom" -> "/viewer";' in dot
    assert "└─ in  /odom ← /w" in to_text(drawn, 80).splitlines()
