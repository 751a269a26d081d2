"""ipyros's own ROS package, ``ipyros_demo``: a small demo robot (Debian and PyPI have no turtlesim).

Its nodes (``turtle_sim``, ``move_base``, ``speed_monitor``) are plain scripts, written once
against :mod:`demonode` and run on rospy or rclpy; ``launch/`` holds their launch files,
``ament/`` makes the package visible to ``ros2 run``'s lookup (the ament index).
:mod:`ipyros.tools.robot` runs them.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["AMENT_PREFIX", "DEMO_DIR", "LAUNCH_DIR"]

#: The package's folder (its package.xml, scripts and launch files).
DEMO_DIR = Path(__file__).resolve().parent
#: The package as an ament prefix of its own, for ROS 2.
AMENT_PREFIX = DEMO_DIR / "ament"
LAUNCH_DIR = DEMO_DIR / "launch"
