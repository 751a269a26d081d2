"""ROS 1 (rospy, ros_comm): everything ipyros does that only ROS 1 does.

The DSL, the node model, the plan, keeping the work and the magics above this package
are the same on any ROS; what runs them on ROS 1 is here, and nowhere else imports
rospy or speaks to a ROS 1 master:

- :mod:`.runtime`: the session's rospy node and its endpoints (publications,
  subscriptions, byte relays, timers, services), parameters;
- :mod:`.sending`: per-connection outboxes, so a slow subscriber never blocks a writer;
- :mod:`.master`, :mod:`.masterwatch`, :mod:`.rosout`: finding or starting the master
  (local only), watching it go and come back, a rosout that listens on loopback;
- :mod:`.launchfile`, :mod:`.launch_rest`: a node of a launch file as a basenode, and
  the rest of the file run by roslaunch.
"""
