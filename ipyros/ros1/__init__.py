"""ROS 1 (rospy, ros_comm): everything ipyros does that only ROS 1 does.

The DSL, the node model, the plan, keeping the work and the magics above this package
are the same on any ROS; what runs them on ROS 1 is here, and nowhere else imports
rospy or speaks to a ROS 1 master:

- :mod:`.backend`: all of it behind :class:`ipyros.node.backend.Backend`;
- :mod:`.runtime`: the session's rospy node and its endpoints (publications,
  subscriptions, byte relays, timers, services), parameters;
  :mod:`.sending`: per-connection outboxes, so a slow subscriber never blocks a writer;
  :mod:`.actions`: actionlib servers, clients, relays and watches (imported on first use);
- :mod:`.master`, :mod:`.masterwatch`, :mod:`.connection`, :mod:`.rosout`: finding or
  starting the master (local only), watching it go and come back, a rosout on loopback;
- :mod:`.graph`, :mod:`.discovery`, :mod:`.introspect`: the graph as a snapshot, a running
  node's interface, services, parameters and nodes for the magics; :mod:`.reconfigure`:
  dynamic_reconfigure servers' parameters, ranges and settings;
- :mod:`.msggen`: a workspace's message package built with genpy;
- :mod:`.nodes`: executables found as rosrun finds them, and a node's command line;
- :mod:`.launchfile`, :mod:`.launch_rest`: a node of a launch file as a basenode, and
  the rest of the file run by roslaunch;
- :mod:`.bagfile`, :mod:`.bag_player`: bags written and played; :mod:`.mcapfile`, :mod:`.mcapread`:
  MCAP files of ROS 1 messages (the reader alone, for the player too); :mod:`.export`: rospy
  scripts and catkin packages.

May import: core, processes, demo. Nothing above the node layer imports it: the node
layer chooses it.
"""

__all__ = ["actions", "backend", "bag_player", "bagfile", "connection", "discovery", "export", "graph", "introspect",
           "launch_rest", "launchfile", "master", "masterwatch", "msggen", "nodes", "reconfigure", "rosout", "runtime",
           "sending"]
