"""The arm's limitations, one kind per module (its data and its compiled rows), registered in
``registry.KINDS``. ``rows.py`` dispatches the compiled step to each kind's row function.

Every row is a measure of the robot state: a signed distance ``d`` [m, or rad for joints],
positive where allowed, and its joint-space gradient ``a`` (``d_dot = a @ qdot + rate``, the
rate being how fast ``d`` changes by itself: a moving human). The filter turns each row into a
half-space on the joint velocity (``cobotsafety.arm.joint_filter``).
"""

from cobotsafety.arm.limitations.box_zone import BoxZone
from cobotsafety.arm.limitations.capsule_zone import CapsuleZone, SphereZone
from cobotsafety.arm.limitations.halfspace_zone import HalfSpaceZone
from cobotsafety.arm.limitations.human import HumanLimitation
from cobotsafety.arm.limitations.joint_range import JointPositionLimits
from cobotsafety.arm.limitations.reach import ReachLimits
from cobotsafety.arm.limitations.table import TablePlane

__all__ = ["BoxZone", "CapsuleZone", "HalfSpaceZone", "HumanLimitation", "JointPositionLimits", "ReachLimits",
           "SphereZone", "TablePlane"]
