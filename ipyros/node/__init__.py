"""The node: what makes a declared node run, and keeps it running as it changes.

- :mod:`.engine`: a node's state and the one place where its model and its live
  endpoints change together (each ``rosNode`` owns one);
- :mod:`.session`: the nodes of this process, its ROS, its notices and history;
- :mod:`.backend`: the seam to ROS (:class:`Backend`), and choosing ``ros1/`` or ``ros2/``;
- :mod:`.wrapping`: a basenode declared, started remapped, and discovered.

May import: core, processes, and the backends (only :mod:`.backend` chooses one).
"""

__all__ = ["backend", "engine", "session", "wrapping"]
