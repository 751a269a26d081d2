"""ROS 2 (rclpy, from PyPI or a ROS 2 install): everything ipyros does that only ROS 2 does.

- :mod:`.runtime`: one ROS 2 node per DSL node, in one context, spun by one executor
  thread; publications, subscriptions, byte relays, timers, services, parameters;
- :mod:`.backend`: those behind :class:`ipyros.backend.Backend`.

So far the DSL runs here (declare, create, reshape live, write, timers, services, a
node's params); wrapping basenodes, discovery, the magics' graph and QoS options are
the next steps (issues 10 and 11).
"""
