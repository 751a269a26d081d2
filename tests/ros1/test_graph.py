"""GraphCache against a real master and real publisher processes (no rospy node in pytest)."""

from __future__ import annotations

import socket
import threading
import time

import pytest
from ros1_fixtures import free_port, master_graph, wait_for
from topic_nodes import many_topics, stop

from ipyros.core.graph import GraphSnapshot
from ipyros.ros1.graph import fetch_snapshot


@pytest.fixture
def graph(ros_master):
    cache = master_graph(ros_master, period=0.1).start()
    assert cache.wait_first(5)
    yield cache
    cache.stop()


def test_topics_appear_with_types_and_nodes_then_disappear(graph):
    with many_topics("graph_pub", 3, "/gt/pose", type="geometry_msgs/Pose", subscribe=("/gt/in",)) as proc:
        # A node registers its topics and services one by one: wait for the last of each kind.
        snap = wait_for(lambda: (s := graph.snapshot) and "/gt/pose0002" in s.topics and "/gt/in" in s.subscribers
                        and "/graph_pub/get_loggers" in s.services and s, timeout=20,
                        what="the publisher's topics in the snapshot")
        assert snap.master_up
        assert snap.topics["/gt/pose0000"] == "geometry_msgs/Pose"
        assert snap.publishers["/gt/pose0001"] == ("/graph_pub",)
        assert snap.subscribers["/gt/in"] == ("/graph_pub",)
        # A topic only subscribed to is still a live topic; an AnyMsg subscriber gives it no type.
        assert snap.topics["/gt/in"] == ""
        assert "/graph_pub" in snap.nodes
        assert "/graph_pub/get_loggers" in snap.services and snap.services["/graph_pub/get_loggers"] == ("/graph_pub",)
        assert snap.taken_at > time.time() - 5
        stop(proc)
        # The master keeps the type of a dead topic forever; the cache must not.
        wait_for(lambda: not graph.snapshot.topics_with_prefix("/gt/"), timeout=20, what="the topics to vanish")
        assert "/graph_pub" not in graph.snapshot.nodes


def test_snapshot_is_immutable_and_sorted(graph):
    with many_topics("graph_sorted", 5, "/gs/t"):
        snap = wait_for(lambda: len(graph.snapshot.topics_with_prefix("/gs/")) == 5 and graph.snapshot, timeout=20,
                        what="5 topics")
    assert list(snap.topics) == sorted(snap.topics) and snap.topic_names == tuple(sorted(snap.topics))
    with pytest.raises(TypeError):
        snap.topics["/x"] = "std_msgs/String"  # type: ignore[index]
    with pytest.raises(AttributeError):
        snap.master_up = False  # type: ignore[misc]


def test_topics_matching_glob_substring_type_node(ros_master):
    with many_topics("match_a", 2, "/m/a/cmd", type="geometry_msgs/Twist"), \
            many_topics("match_b", 2, "/m/b/pose", type="geometry_msgs/Pose", subscribe=("/m/a/cmd0000",)):
        graph = master_graph(ros_master)
        snap = wait_for(lambda: (s := graph.refresh_now(2)) and len(s.topics_with_prefix("/m/")) == 4
                        and "/m/a/cmd0000" in s.subscribers and s, timeout=20, what="4 topics under /m/")
        assert graph.topics_matching("/m/*/cmd*") == ["/m/a/cmd0000", "/m/a/cmd0001"]
        assert snap.topics_matching("b/pose") == ["/m/b/pose0000", "/m/b/pose0001"]  # a substring
        assert snap.topics_matching("/m/", type="geometry_msgs/Twist") == ["/m/a/cmd0000", "/m/a/cmd0001"]
        assert snap.topics_matching("/m/", type="geometry_msgs/*") == snap.topics_with_prefix("/m/")
        # A node matches the topics it publishes and those it subscribes to.
        assert snap.topics_matching("/m/", node="/match_b") == ["/m/a/cmd0000", "/m/b/pose0000", "/m/b/pose0001"]
        assert snap.topics_matching("nothing-like-this") == []
        assert snap.nodes_with_prefix("/match_") == ["/match_a", "/match_b"]


def test_master_down_is_empty_fast_and_quiet():
    uri = f"http://127.0.0.1:{free_port()}/"  # nothing listens there
    with master_graph(uri, period=0.05) as graph:
        assert graph.wait_first(1)
        snap = graph.refresh_now()
        assert snap.master_up is False and not snap.topics and not snap.nodes and not snap.services
        assert graph.snapshot.master_up is False
    assert not graph.running


def test_silent_master_is_bounded_by_the_socket_timeout():
    """A master that accepts the connection but never answers must not hang the reader."""
    with socket.socket() as listener:
        listener.bind(("127.0.0.1", 0))
        listener.listen(8)  # the kernel completes the handshake; nobody ever reads or writes
        uri = "http://127.0.0.1:%d/" % listener.getsockname()[1]
        snap = fetch_snapshot(uri, timeout=0.3)  # unbounded, this would never return (the test's timeout fails it)
        assert snap.master_up is False
        graph = master_graph(uri, period=0.05, timeout=0.2).start()
        assert graph.wait_first(2)
        graph.stop()  # joins the thread, which may be mid-call: bounded by the timeout, or it would hang
        assert not graph.running


def test_start_stop_leave_no_thread(ros_master):
    graph = master_graph(ros_master, period=0.05)
    assert graph.start() is graph and graph.start() is graph  # idempotent
    assert graph.wait_first(5) and graph.snapshot.master_up
    graph.stop()
    graph.stop()  # idempotent too
    assert not any(t.name == "ipyros-graph" for t in threading.enumerate())
    assert graph.snapshot.master_up  # the last snapshot stays readable
    graph.start()
    assert graph.running
    graph.stop()
    assert not graph.running


def test_empty_snapshot_before_first_refresh():
    snap = master_graph("http://127.0.0.1:1/").snapshot
    assert snap == GraphSnapshot() and snap.master_up is False and snap.taken_at == 0.0
    assert snap.topics_with_prefix("/") == [] and snap.topics_matching("*") == []
