"""Processes: the children a session starts, started so that none outlives it.

- :mod:`.process`: spawning in a process group of its own, killed with the session even
  if it is killed; stopping SIGINT, SIGTERM, SIGKILL;
- :mod:`.basenode`: a basenode run from its command line, its log, and its exit told;
- :mod:`.launched`: a basenode from a launch file and the rest of the file, as one handle.

May import: core. Which command line a basenode has is its backend's (``ros1/nodes.py``,
``ros2/nodes.py``).
"""

__all__ = ["basenode", "launched", "process"]
