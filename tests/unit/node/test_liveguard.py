"""A running node's guard when its process is lost (:mod:`ipyros.node.liveguard`), pure: the session fails closed, and
says once when it cannot even send the stop message (nothing else passes, but nothing stops the robot either)."""

from __future__ import annotations

from typing import Any

import pytest
from unit_msgs.msg import Twist

from ipyros.core.model import GuardModel, TopicModel
from ipyros.node.liveguard import LiveGuard


class LostSentinel:
    """What a guard sees of a sentinel process that was killed."""

    running, returncode, log_path = False, -9, "/var/log/guard.log"


@pytest.fixture
def lost():
    """A guard of /cmd_vel whose process was killed, its session's sending what ``outcome`` says: True sent, False no
    output open, an exception raised; each stop message it sends is counted."""
    sent: list[Any] = []
    outcome: list[Any] = [True]

    def send(topic: str, msg: Any) -> bool:
        if isinstance(outcome[0], Exception):
            raise outcome[0]
        sent.append(msg)
        return outcome[0]

    model = GuardModel("/cmd_vel", "/cmd_vel", "unit_msgs/Twist", repeat=4.0)
    guard = LiveGuard(model, TopicModel("/cmd_vel", "/cmd_vel", "out", "unit_msgs/Twist"), None, lambda text: None,
                      send)
    guard.sentinel = LostSentinel()
    yield guard, sent, outcome
    guard.shared.close()


def test_a_lost_process_is_said_once_and_the_session_sends_the_stop_message_at_its_rate(lost):
    guard, sent, _ = lost
    said = guard.tend(100.0)
    assert len(said) == 1 and said[0].startswith("guard /cmd_vel: its process ended (killed by signal 9;")
    assert guard.holding() and [type(m) for m in sent] == [Twist]
    assert guard.tend(100.1) == [] and len(sent) == 1  # within 1/repeat: not again yet
    assert guard.tend(100.25) == [] and len(sent) == 2


@pytest.mark.parametrize("failure, why", [(RuntimeError("publisher closed"), "publisher closed"),
                                          (False, "the node has no output open on it")])
def test_a_stop_message_the_session_cannot_send_is_said_once_until_it_can_again(lost, failure, why):
    guard, _, outcome = lost
    guard.tend(100.0)
    outcome[0] = failure
    (said,) = guard.tend(100.25)
    assert said == (f"guard /cmd_vel: the session cannot send the stop message ({why}): nothing else passes, but no "
                    "stop message reaches the robot from here; stop it with its own e-stop")
    assert guard.tend(100.5) == [] and guard.tend(100.75) == []  # tried again each time, said once
    assert guard.holding()  # still failing closed: every message is replaced by the stop message
    outcome[0] = True
    assert guard.tend(101.0) == ["guard /cmd_vel: the session sends the stop message again"]
