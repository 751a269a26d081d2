"""ROS 2 (rclpy, from PyPI or a ROS 2 install): everything ipyros does that only ROS 2 does.

- :mod:`.backend`: all of it behind :class:`ipyros.node.backend.Backend`;
- :mod:`.runtime`: one ROS 2 node per DSL node, in one context, spun by one supervised
  executor thread; publications, subscriptions, byte relays, timers, services, parameters,
  and a basenode's interface read from the graph; :mod:`.graph`: the graph as a snapshot;
  :mod:`.actions`: rclpy.action servers (goals on threads of their own), clients, relays, watches;
- :mod:`.nodes`: a package's executables as ``ros2 run`` finds them (the ament index), and
  a node's command line; :mod:`.fastdds`: ipyros's Fast DDS profile;
- :mod:`.launchfile`: XML and YAML launch files read without the launch package;
  :mod:`.launch_rest`: a launch file's other nodes started beside the wrapped one;
- :mod:`.msggen`: a workspace's message package built (rosidl generators, the C compiler);
- :mod:`.introspect`: services, parameters and nodes of the graph, for the magics;
- :mod:`.bagfile`, :mod:`.bag_player`: bags written and played; :mod:`.export`: rclpy scripts.

May import: core, processes, demo (the demo package's ament prefix). Nothing above the
node layer imports it: the node layer chooses it.
"""

__all__ = ["actions", "backend", "bag_player", "bagfile", "export", "fastdds", "graph", "introspect", "launch_rest",
           "launchfile", "msggen", "nodes", "runtime"]
