"""The e-stop over several nodes asks every node, whatever another one did, and then says what failed."""

from __future__ import annotations

import pytest

from ipyros.core.errors import IpyrosError
from ipyros.tools.estop import estop_each


class Node:
    """A node as the e-stop sees it: its name, and guards that hold (or cannot be reached)."""

    def __init__(self, name: str, topics: list[str], fails: bool = False) -> None:
        self.name, self.topics, self.fails, self.asked = name, topics, fails, 0

    def estop(self) -> list[str]:
        self.asked += 1
        if self.fails:
            raise IpyrosError("its keeper on robot1 does not answer")
        return self.topics

    release = estop


def test_every_node_is_asked_when_one_fails_and_the_error_says_what_held():
    nodes = [Node("a", ["/a/cmd"]), Node("b", ["/b/cmd"], fails=True), Node("c", ["/c/cmd"])]
    with pytest.raises(IpyrosError, match=r"could not be e-stopped: b: its keeper on robot1 does not answer; "
                                          r"e-stopped all the same: /a/cmd \(a\), /c/cmd \(c\)"):
        estop_each(nodes)
    assert [n.asked for n in nodes] == [1, 1, 1]


def test_each_node_with_what_it_held():
    a, c = Node("a", ["/a/cmd"]), Node("c", ["/c/cmd", "/c/arm"])
    assert estop_each([a, c], on=False) == [(a, ["/a/cmd"]), (c, ["/c/cmd", "/c/arm"])]
