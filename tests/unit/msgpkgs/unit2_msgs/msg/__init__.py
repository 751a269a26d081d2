from unit2_msgs.msg._pose import Point  # noqa: F401
from unit2_msgs.msg._pose import Pose  # noqa: F401
