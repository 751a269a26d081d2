"""ROS 2 (rclpy, from PyPI or a ROS 2 install): everything ipyros does that only ROS 2 does.

- :mod:`.runtime`: one ROS 2 node per DSL node, in one context, spun by one executor
  thread; publications, subscriptions, byte relays, timers, services, parameters, and
  a basenode's interface read from the graph;
- :mod:`.packages`: a package's executables as ``ros2 run`` finds them (the ament index);
- :mod:`.backend`: those behind :class:`ipyros.node.backend.Backend`.

The DSL and wrapping run here; the magics' view of the graph (%topics, %echo, %pub,
completion of live names) and a qos= option are the next steps (issues 10 and 11).
"""
