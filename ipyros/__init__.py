"""ipyros: interactive, incremental programming of ROS nodes (ROS 1 and ROS 2) from IPython.

``from ipyros import rosNode`` gives the DSL of Adam & Schultz; ``%load_ext ipyros``
adds the magics and live tab completion on top of it.
"""

from __future__ import annotations

__version__ = "0.1.0"

from .core.errors import IpyrosError  # noqa: E402
from .core.rules import rule  # noqa: E402
from .dsl import build_messages, restore, restoring, rosNode, save_session, shutdown, spin  # noqa: E402
from .tools.robot import demo_robot, stop_demo_robot  # noqa: E402

__all__ = ["rosNode", "rule", "IpyrosError", "save_session", "restore", "restoring", "shutdown", "spin", "demo_robot",
           "stop_demo_robot", "build_messages", "load_ipython_extension", "unload_ipython_extension"]


def load_ipython_extension(ipython):  # noqa: D103 - documented in ipyros.ipython.extension
    # Imported here, not above: a saved node run by plain python3 imports ipyros, not IPython.
    from .ipython.extension import load_ipython_extension as load  # noqa: PLC0415

    load(ipython)


def unload_ipython_extension(ipython):  # noqa: D103
    from .ipython.extension import unload_ipython_extension as unload  # noqa: PLC0415 - as above

    unload(ipython)
