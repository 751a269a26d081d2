"""The unit layer: no ROS. Message classes of the shapes ipyros reads (genpy's, rosidl's) come from the packages
in ``msgpkgs/`` (see its README), importable here as ``unit_msgs`` and ``unit2_msgs``."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

MSGPKGS = Path(__file__).resolve().parent / "msgpkgs"
sys.path.insert(0, str(MSGPKGS))


@pytest.fixture(autouse=True, scope="session")
def _message_index_sees_the_unit_packages():
    from ipyros.core import msgtypes

    msgtypes.forget_index()
    yield
