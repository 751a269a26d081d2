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


def test_a_global_bound_already_under_another_meaning_is_refused_not_silently_shared():
    """The file holds one binding a name: a second handler whose global of that name is another value would
    silently read the first's (the fourth hostile round: ``rospy = 5`` read as the module)."""
    import pytest

    from ipyros.core.errors import IpyrosError

    bindings = Bindings(imports={"rospy": ("rospy", None)})
    mine = {"rospy": 5, "GAINS": [1.0]}
    exec("def scale(msg):\n    return msg * rospy\n", mine)  # noqa: S102 - a handler of the user's
    with pytest.raises(IpyrosError, match=r"^handler scale reads the global rospy = 5, but rospy is the module "
                                          r"rospy in the file; rename the global"):
        bindings.bind(mine["scale"], "def scale(msg):\n    return msg * rospy\n", None)
    bindings = Bindings()
    bindings.bind(steer, "def steer(msg):\n    return sum(GAINS) * msg\n", None)
    exec("def other(msg):\n    return GAINS\n", mine)  # noqa: S102
    with pytest.raises(IpyrosError, match=r"reads the global GAINS = \[1.0\], but GAINS is \[0.5"):
        bindings.bind(mine["other"], "def other(msg):\n    return GAINS\n", None)
    bindings.bind(remember, "def remember(msg):\n    SEEN.append(msg)\n", None)  # the same value: one binding
    bindings.bind(steer, "def steer(msg):\n    return sum(GAINS) * msg\n", None)
