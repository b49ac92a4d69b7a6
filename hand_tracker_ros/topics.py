"""The tracker's output topics: one table for the live graph, the offline bags and the tools.

Every output is under the ``hand/`` namespace except the two topics ROS tools expect at a fixed
name, ``/tf`` and ``/diagnostics``. The names are relative, so a node namespace
(``__ns:=/left``) or a remap (``-r hand/state:=/my/state``) moves them; the estimates bags of
``hand-tracker track`` hold them at the root (``/hand/state``, ...), as the live graph does in
the root namespace. Ground truth of synthetic bags lives beside them under
``hand/ground_truth/``.

==========================  ===================================  ==================================
topic                       type                                 content
==========================  ===================================  ==================================
hand/joint_states           sensor_msgs/msg/JointState           the pose, named as the URDF
                                                                 joints (only while TRACKING)
hand/state                  hand_tracker_msgs/msg/HandState      every set: status, confidence,
                                                                 pose, keypoints, costs
hand/markers                visualization_msgs/msg/MarkerArray   skeleton, joints, fingertips;
                                                                 DELETEALL when not TRACKING
hand/robot_description      std_msgs/msg/String                  the URDF, latched (transient
                                                                 local)
/tf                         tf2_msgs/msg/TFMessage               every URDF joint's transform
                                                                 (only while TRACKING)
/diagnostics                diagnostic_msgs/msg/DiagnosticArray  input rates, sync, latency
hand/observation_plan       hand_tracker_msgs/msg/ObservationPlan  distributed graph: what the
                                                                 features and salient_points
                                                                 processes observe next
==========================  ===================================  ==================================
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class Topic:
    """One output topic.

    Attributes
    ----------
    name : str
        Relative name (``hand/state``) or absolute for fixed ROS names (``/tf``).
    msgtype : str
        ROS 2 type, ``pkg/msg/Name``.
    latched : bool
        Published once with transient-local durability (late subscribers get it).
    """

    name: str
    msgtype: str
    latched: bool = False

    @property
    def absolute(self) -> str:
        """The name in the root namespace (as bags and ``topics echo`` show it)."""
        return self.name if self.name.startswith('/') else f'/{self.name}'


JOINT_STATES = Topic('hand/joint_states', 'sensor_msgs/msg/JointState')
STATE = Topic('hand/state', 'hand_tracker_msgs/msg/HandState')
MARKERS = Topic('hand/markers', 'visualization_msgs/msg/MarkerArray')
ROBOT_DESCRIPTION = Topic('hand/robot_description', 'std_msgs/msg/String', latched=True)
TF = Topic('/tf', 'tf2_msgs/msg/TFMessage')
DIAGNOSTICS = Topic('/diagnostics', 'diagnostic_msgs/msg/DiagnosticArray')
# With inputs:=features only: the tracker's attention for the upstream processes
# (ros_io/plans.py).
OBSERVATION_PLAN = Topic('hand/observation_plan', 'hand_tracker_msgs/msg/ObservationPlan')

# What a tracked set produces, in the order it is published and written.
ESTIMATES = (JOINT_STATES, STATE, MARKERS, TF)
# Everything the tracker node publishes besides the per-camera overlays.
TRACKER_OUTPUTS = (*ESTIMATES, ROBOT_DESCRIPTION, DIAGNOSTICS)

GT_JOINT_STATES = Topic('hand/ground_truth/joint_states', 'sensor_msgs/msg/JointState')
GT_STATE = Topic('hand/ground_truth/state', 'hand_tracker_msgs/msg/HandState')


def overlay_topic(camera: str) -> str:
    """The tracker's overlay image topic of ``camera`` (relative, ``sensor_msgs/msg/Image``)."""
    return f'{camera}/overlay'
