"""QoS as plain data: what a declaration's qos= may be, the same on both ROS."""

from __future__ import annotations

import pytest

from ipyros.core import qos
from ipyros.core.errors import DeclarationError
from ipyros.core.qos import Qos


@pytest.mark.parametrize("given, expected", [
    (None, Qos()),
    ("sensor_data", Qos(5, "best_effort", "volatile")),
    ("latched", Qos(1, "reliable", "transient_local")),
    (50, Qos(depth=50)),
    ({"depth": 3, "reliability": "best_effort"}, Qos(3, "best_effort", None)),
    ({"profile": "sensor_data", "depth": 50}, Qos(50, "best_effort", "volatile")),
    (Qos(7), Qos(7)),
])
def test_what_qos_may_be(given, expected):
    assert qos.parse(given, "here") == expected


@pytest.mark.parametrize("bad, message", [
    ("fast", "is not a profile"), (0, "from 1 to 100000"), (True, "is a bool"), (2.5, "is a float"),
    ({"depth": -1}, "from 1 to 100000"), ({"reliability": "sometimes"}, "reliability"),
    ({"durability": "forever"}, "durability"), ({"history": 3}, "qos has no field history"),
])
def test_bad_qos_is_one_line_naming_the_declaration(bad, message):
    with pytest.raises(DeclarationError) as caught:
        qos.parse(bad, "new.publish('/x')")
    text = str(caught.value)
    assert text.startswith("new.publish('/x'): ") and message in text and "\n" not in text


def test_model_round_trip_and_text():
    given = Qos(5, "best_effort", None)
    assert given.to_model() == {"depth": 5, "reliability": "best_effort"}
    assert qos.from_model(given.to_model()) == given
    assert Qos().to_model() is None and qos.from_model(None) == Qos()
    assert str(Qos(5, "best_effort", "transient_local")) == "best-effort transient-local depth 5"
    assert str(Qos()) == "default"
    assert Qos(durability="transient_local").latched and not Qos().latched
