"""Basenode for the action tests on ROS 1: serves ``count`` (actionlib/Test, actionlib's own test action), name relative.

A goal N sends the feedbacks 1..N, one every 0.05 s, then succeeds with result N. It
prints "goal N" when a goal comes and "cancelled N" when a cancel reaches it (the goal
then ends preempted). Spins until killed.
"""
import actionlib
import rospy
from actionlib.msg import TestAction, TestFeedback, TestResult

rospy.init_node("count_server")


def execute(goal):
    print(f"goal {goal.goal}", flush=True)
    for i in range(1, goal.goal + 1):
        if server.is_preempt_requested():
            print(f"cancelled {goal.goal}", flush=True)
            server.set_preempted(TestResult(result=i - 1))
            return
        server.publish_feedback(TestFeedback(feedback=i))
        rospy.sleep(0.05)
    server.set_succeeded(TestResult(result=goal.goal))


server = actionlib.SimpleActionServer("count", TestAction, execute, auto_start=False)
server.start()
print("count_server ready", flush=True)
rospy.spin()
