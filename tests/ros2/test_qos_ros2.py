"""QoS on ROS 2: ``qos=`` on declarations, relays that take their source's QoS, mismatches told."""

from __future__ import annotations

from pathlib import Path

import pytest
from ros2_fixtures import wait_for
from std_msgs.msg import String

from ipyros.core import errors
from ipyros.dsl import engine_of
from ipyros.ipython.display import node_table

ECHO_NODE = str(Path(__file__).resolve().parent / "peers" / "echo_node.py")


def test_a_subscription_that_cannot_match_is_told_and_qos_makes_it_match(make_node, notices):
    """A best-effort publisher and a reliable subscription connect nothing in ROS 2, silently; ipyros says so.
    A subscription declared without qos= takes the publishers' and hears them."""
    sensor = make_node("q_sensor").new.publish("/q/scan", type=String, qos="sensor_data").create()
    strict, loose, plain = [], [], []
    make_node("q_strict").new.subscribe("/q/scan", lambda m: strict.append(m.data), type=String,
                                        qos="reliable").create()
    make_node("q_loose").new.subscribe("/q/scan", lambda m: loose.append(m.data), type=String,
                                       qos={"reliability": "best_effort", "depth": 20}).create()
    make_node("q_plain").new.subscribe("/q/scan", lambda m: plain.append(m.data), type=String).create()
    wait_for(lambda: any("/q/scan" in n and "incompatible reliability" in n for n in notices), timeout=10,
             what="the mismatch to be told")
    told = next(n for n in notices if "incompatible reliability" in n)
    assert told.startswith("ipyros: q_") and ("/q_sensor (best-effort volatile)" in told or "/q_strict" in told), told
    assert "subscribe with qos='best_effort'" in told and "\n" not in told
    wait_for(lambda: sensor.write("/q/scan", String(data="ping")) or (loose and plain), timeout=10, interval=0.1,
             what="the best-effort and the undeclared subscriptions to get the best-effort publisher's messages")
    assert strict == []
    assert not [n for n in notices if "q_plain" in n], notices


def test_qos_is_in_the_model_the_table_and_refused_when_it_makes_no_sense(make_node):
    nd = make_node("q_model")
    nd.new.publish("/q/map", type=String, qos={"profile": "latched", "depth": 3})
    nd.new.subscribe("/q/cloud", print, type=String, qos=7)
    assert nd.model().topic("/q/map", "publish").qos == {"depth": 3, "reliability": "reliable",
                                                         "durability": "transient_local"}
    assert nd.model().topic("/q/cloud", "subscribe").qos == {"depth": 7}
    table = _text(node_table(nd))
    assert "publish (reliable transient-local depth 3)" in table and "subscribe (depth 7)" in table, table
    for qos, text in [("sensor", "qos='sensor' is not a profile; give one of default, sensor_data"),
                      ({"depth": 0}, "qos depth 0 must be a whole number from 1 to 100000"),
                      ({"reliability": "sometimes"}, "qos reliability 'sometimes' must be one of reliable, best_effort"),
                      ({"history": "all"}, "qos has no field history"),
                      (2.5, "qos=2.5 is a float")]:
        with pytest.raises(errors.DeclarationError, match=text.replace("(", r"\(").replace(")", r"\)")):
            nd.new.subscribe("/q/bad", print, type=String, qos=qos)
    with pytest.raises(errors.DeclarationError, match="latch=True and a volatile qos contradict each other"):
        nd.new.publish("/q/bad", type=String, latch=True, qos="default")
    assert nd.model().topic("/q/bad", "subscribe") is None and nd.model().topic("/q/bad", "publish") is None
    w = make_node("q_wrapper")
    w.baseNode(ECHO_NODE)
    with pytest.raises(errors.DeclarationError, match="a reuse relay takes the QoS of the publishers it relays"):
        w.reuse.publish("out", type=String, qos="sensor_data")


def _text(renderable) -> str:
    from rich.console import Console

    console = Console(width=200, record=True)
    console.print(renderable)
    return console.export_text()


def test_a_relay_takes_the_qos_of_a_best_effort_basenode(make_node, notices):
    """A sensor-like basenode publishes best-effort: the relay matches it and relays best-effort."""
    heard: list[str] = []
    feeder = make_node("q_feeder").new.publish("/robot7/in", type=String).create()
    make_node("q_listener").new.subscribe("/robot7/out", lambda m: heard.append(m.data), type=String,
                                          qos="sensor_data").create()
    w = make_node("q_w")
    w.baseNode(ECHO_NODE, namespace="robot7", params={"prefix": "S:", "sensor": True})
    w.reuse.subscribe("in", type=String).publish("out", type=String)
    w.create()
    wait_for(lambda: feeder.write("/robot7/in", String(data="x")) or heard, timeout=20, interval=0.2,
             what="the best-effort output through the relay")
    assert heard[0] == "S:x"
    relay = next(f for f in engine_of(w).sent() if f.topic == "/robot7/out")
    assert relay.messages >= 1
    assert not [n for n in notices if "incompatible" in n], notices


def test_topics_verbose_shows_deadline_and_liveliness(make_node, session):
    """%topics -v (the backend's topic_endpoints): an endpoint's deadline and manual liveliness, which decide what
    matches as much as reliability does (issue 25)."""
    from rclpy.duration import Duration
    from rclpy.qos import LivelinessPolicy, QoSProfile

    host = make_node("qos_deadline").create()
    node = session.process.host(host.fullname)
    publisher = node.create_publisher(String, "/qos_deadline/out", QoSProfile(
        depth=3, deadline=Duration(seconds=0.25), liveliness=LivelinessPolicy.MANUAL_BY_TOPIC,
        liveliness_lease_duration=Duration(seconds=2)))
    try:
        shown = wait_for(lambda: session.backend.topic_endpoints("/qos_deadline/out"), timeout=20,
                         what="the publisher in the graph")
        # (no depth: discovery does not carry it)
        assert shown[0][3] == "reliable volatile deadline 0.25 s liveliness manual-by-topic lease 2 s", shown
    finally:
        node.destroy_publisher(publisher)


STATUS_ONCE = str(Path(__file__).resolve().parents[1] / "both" / "peers" / "status_once.py")


def test_a_relayed_latched_message_reaches_a_late_subscriber_every_run(make_node):
    """A basenode publishes its status once, transient-local, at start; the reuse relay takes its QoS when its
    publisher shows up. Whether the relay's first (volatile) subscription heard the message before the swap or
    its new one hears it again after, a subscriber that joins later gets it, and gets it once (issue 24)."""
    w = make_node("latch_relay")
    w.baseNode(STATUS_ONCE, namespace="latch_relay_robot")
    w.reuse.publish("status", type=String)
    for run in range(5):  # the race is in each start: each run is a trial of it
        w.create()
        wait_for(lambda: any("ready" in line for line in w.base.tail()), what="the basenode's one status")
        heard: list[str] = []
        late = make_node(f"latch_late_{run}").new.subscribe("/latch_relay_robot/status", heard.append, type=String,
                                                            qos="transient_local").create()
        wait_for(lambda: heard, timeout=15, what=f"the latched status (run {run + 1} of 5)")
        late.shutdown()
        w.shutdown()
        assert len(heard) == 1, f"run {run + 1}: heard {len(heard)} times"
