"""What a saved handler takes along: a container it fills is data (kept empty), one it reads is configuration."""

from __future__ import annotations

from ipyros.core.code import Bindings

GAINS = [0.5] * 60
SEEN: list = [1.0] * 60


def steer(msg):
    return sum(GAINS) * msg


def remember(msg):
    SEEN.append(msg)


def test_a_list_a_handler_reads_is_copied_and_one_it_fills_starts_empty():
    bindings = Bindings()
    bindings.bind(steer, "def steer(msg):\n    return sum(GAINS) * msg\n", None)
    bindings.bind(remember, "def remember(msg):\n    SEEN.append(msg)\n", None)
    assert bindings.values["GAINS"] == f"GAINS = {GAINS!r}"
    assert bindings.values["SEEN"] == "SEEN = list()  # filled by remember: its data is not kept"
