"""``/rosout`` for the master ipyros starts: what roscore's rosout does, listening on loopback only.

Every ROS node publishes its log lines on ``/rosout``; roscore's ``rosout`` node gathers them
on ``/rosout_agg`` (which rqt_console and ``rostopic echo /rosout_agg`` read). Debian's
rosout is a roscpp node, and roscpp's XML-RPC server listens on every interface whatever
``ROS_IP`` says; this rospy one binds where ``ROS_IP`` tells it (127.0.0.1 for the embedded
master, see :mod:`ipyros.ros1.master`). Run as ``python -m ipyros.ros1.rosout``.
"""

from __future__ import annotations


def main() -> None:
    import rospy
    from rosgraph_msgs.msg import Log

    rospy.init_node("rosout", disable_rosout=True)  # its own lines would come back to it
    aggregated = rospy.Publisher("/rosout_agg", Log, queue_size=1000)
    rospy.Subscriber("/rosout", Log, aggregated.publish, queue_size=1000)
    rospy.spin()


if __name__ == "__main__":
    main()
