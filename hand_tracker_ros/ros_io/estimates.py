"""TrackResult -> the tracker's output messages: one conversion for the live graph and the bags.

:class:`EstimateEncoder` is what the tracker node publishes and what ``hand-tracker track``
writes into its estimates bag, built with the node's rclpy classes or the bag's rosbags classes
(:mod:`.message_kit`). Topics and types: :mod:`hand_tracker_ros.topics`.

Every message carries ``header.stamp`` = the input set's stamp and ``header.frame_id`` = the
world frame. Per set, in this order:

- ``hand/robot_description`` (only when the result's model is not the one of the last set,
  e.g. after the session refined the hand's scale; the first is the caller's to send): the
  URDF at the new shape, which TF, the markers and HandState's shape follow from this set on;
- ``hand/joint_states`` (only when TRACKING): ``PARAM_NAMES`` and ``theta`` (m, rad);
- ``hand/state`` (every set, LOST included, with the rejected estimate): status, confidence,
  pose, keypoints and fingertips (m), shape, per-term costs (names sorted), iterations and
  the processing time the caller measured;
- ``hand/markers``: one list marker per kind, ``id`` 0 in its namespace; a single
  ``DELETEALL`` marker when the set is not TRACKING;
- ``/tf`` (only when TRACKING): one ``TransformStamped`` per URDF joint, parent link ->
  child link, at the estimate (:func:`hand_tracker_ros.model.urdf.joint_transforms`), as
  ``robot_state_publisher`` would send it from the JointState; the root link is the world
  frame, so ``hand/robot_description`` (the URDF with that root) and TF agree link for link.

============  =============  ===========================================================
ns            type           content
============  =============  ===========================================================
skeleton      LINE_LIST      the 20 bones between the 21 keypoints
joints        SPHERE_LIST    the 21 keypoints
fingertips    SPHERE_LIST    the 5 fingertip surface points (thumb .. pinky)
mesh          TRIANGLE_LIST  the posed mesh (only with ``publish_mesh``, the node's parameter)
============  =============  ===========================================================

No ROS package is imported here: the kit brings the message classes.
"""
from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np

from hand_tracker_ros import topics
from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.core.result import TrackResult
from hand_tracker_ros.geometry.rotations import quaternions_xyzw_from_matrices
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.layout import PARAM_NAMES
from hand_tracker_ros.model.shape import SHAPE_NAMES
from hand_tracker_ros.model.skeleton import KEYPOINT_NAMES
from hand_tracker_ros.model.urdf import joint_transforms, urdf_joints, urdf_text
from hand_tracker_ros.ros_io.message_kit import MessageKit
from hand_tracker_ros.status import TrackStatus
from hand_tracker_ros.tracking.overlay import KEYPOINT_PARENTS

BONE_WIDTH_M = 0.003
JOINT_DIAMETER_M = 0.008
FINGERTIP_DIAMETER_M = 0.012
_MARKER = 'visualization_msgs/msg/Marker'


def header(kit: MessageKit, stamp_ns: int, frame_id: str) -> Any:
    """A ``std_msgs/Header`` with ``stamp_ns`` (int ns) and ``frame_id``."""
    sec, nanosec = divmod(int(stamp_ns), 10**9)
    return kit.new('std_msgs/msg/Header', frame_id=frame_id,
                   stamp=kit.new('builtin_interfaces/msg/Time', sec=sec, nanosec=nanosec))


def _points(kit: MessageKit, xyz_m: FloatArray) -> list[Any]:
    return [kit.new('geometry_msgs/msg/Point', x=float(x), y=float(y), z=float(z))
            for x, y, z in xyz_m]


def _identity_pose(kit: MessageKit) -> Any:
    # Set explicitly: rosbags does not know the .msg default w = 1 of Quaternion.
    return kit.new('geometry_msgs/msg/Pose',
                   orientation=kit.new('geometry_msgs/msg/Quaternion', w=1.0))


def _marker(kit: MessageKit, head: Any, ns: str, kind: str, scale_m: float,
            rgba: tuple[float, float, float, float], xyz_m: FloatArray) -> Any:
    return kit.new(
        _MARKER, header=head, ns=ns, id=0, type=kit.constant(_MARKER, kind),
        action=kit.constant(_MARKER, 'ADD'), pose=_identity_pose(kit),
        scale=kit.new('geometry_msgs/msg/Vector3', x=scale_m, y=scale_m, z=scale_m),
        color=kit.new('std_msgs/msg/ColorRGBA', r=rgba[0], g=rgba[1], b=rgba[2], a=rgba[3]),
        points=_points(kit, xyz_m))


class EstimateEncoder:
    """The messages of each estimate, for one hand model and world frame.

    Parameters
    ----------
    kit : MessageKit
        Message classes: :class:`.message_kit.RclpyKit` (node) or ``RosbagsKit`` (bags).
    model : HandModel
        The tracked model (its shape goes into HandState and the URDF); a result posed with
        another model switches to that one.
    world_frame : str
        Frame of every output and root link of the URDF and TF.
    publish_mesh : bool
        Also send the posed mesh as a marker.
    """

    def __init__(self, kit: MessageKit, model: HandModel, world_frame: str,
                 publish_mesh: bool = False) -> None:
        self.kit = kit
        self.world_frame = world_frame
        self.publish_mesh = publish_mesh
        self._use(model)

    def _use(self, model: HandModel) -> None:
        """Encode for ``model``: its shape and URDF joints."""
        self.model = model
        self.joints = urdf_joints(model, root_link=self.world_frame)

    def messages(self, result: TrackResult, processing_time_s: float
                 ) -> Iterator[tuple[topics.Topic, Any]]:
        """``(topic, message)`` for one estimate, in the order of the module docstring.

        Each message is built when it is asked for, so a node that publishes as it iterates
        sends the pose before it builds the markers and TF (1.1 of the 1.3 ms the four take);
        should building one fail, the messages before it are out. A writer that wants all or
        none takes ``list()`` of it first.
        ``processing_time_s`` (s) goes into HandState: the node's receipt-to-publication time,
        or offline the result's ``timings_s['total']``.
        """
        if result.posed.model is not self.model:
            self._use(result.posed.model)
            yield topics.ROBOT_DESCRIPTION, self.robot_description()
        tracking = result.status == TrackStatus.TRACKING
        if tracking:
            yield topics.JOINT_STATES, self.joint_state(result)
        yield topics.STATE, self.hand_state(result, processing_time_s)
        yield topics.MARKERS, self.markers(result)
        if tracking:
            yield topics.TF, self.tf(result)

    def robot_description(self) -> Any:
        """``std_msgs/String`` with the URDF whose root link is the world frame."""
        return self.kit.new('std_msgs/msg/String',
                            data=urdf_text(self.model, root_link=self.world_frame))

    def joint_state(self, result: TrackResult) -> Any:
        """The estimate as a JointState named as the URDF joints (positions only)."""
        return self.kit.new('sensor_msgs/msg/JointState',
                            header=header(self.kit, result.stamp_ns, self.world_frame),
                            name=list(PARAM_NAMES), position=self.kit.floats(result.theta))

    def hand_state(self, result: TrackResult, processing_time_s: float) -> Any:
        """Every field of HandState from one result (also for LOST: the rejected estimate)."""
        kit = self.kit
        energy_names = sorted(result.energy_costs)
        return kit.new(
            'hand_tracker_msgs/msg/HandState',
            header=header(kit, result.stamp_ns, self.world_frame), status=int(result.status),
            confidence=float(result.confidence), joint_names=list(PARAM_NAMES),
            joint_positions=kit.floats(result.theta), keypoint_names=list(KEYPOINT_NAMES),
            keypoints=_points(kit, result.posed.keypoints_m),
            fingertips=_points(kit, result.posed.fingertips_m), shape_names=list(SHAPE_NAMES),
            shape_parameters=kit.floats(self.model.shape.to_vector()),
            energy_names=energy_names,
            energy_costs=kit.floats(np.array([result.energy_costs[n] for n in energy_names])),
            iterations=int(result.iterations), processing_time=float(processing_time_s))

    def markers(self, result: TrackResult) -> Any:
        """Skeleton, joints, fingertips (and the mesh); DELETEALL when not TRACKING."""
        kit = self.kit
        head = header(kit, result.stamp_ns, self.world_frame)
        if result.status != TrackStatus.TRACKING:
            return kit.new('visualization_msgs/msg/MarkerArray', markers=[kit.new(
                _MARKER, header=head, action=kit.constant(_MARKER, 'DELETEALL'),
                pose=_identity_pose(kit))])
        keypoints = result.posed.keypoints_m
        bones = np.ravel([(p, k) for k, p in enumerate(KEYPOINT_PARENTS) if p >= 0])
        markers = [
            _marker(kit, head, 'skeleton', 'LINE_LIST', BONE_WIDTH_M, (0.9, 0.9, 0.9, 1.0),
                    keypoints[bones]),
            _marker(kit, head, 'joints', 'SPHERE_LIST', JOINT_DIAMETER_M,
                    (0.9, 0.2, 0.2, 1.0), keypoints),
            _marker(kit, head, 'fingertips', 'SPHERE_LIST', FINGERTIP_DIAMETER_M,
                    (0.2, 0.8, 0.2, 1.0), result.posed.fingertips_m)]
        if self.publish_mesh:
            markers.append(_marker(kit, head, 'mesh', 'TRIANGLE_LIST', 1.0,
                                   (0.95, 0.75, 0.6, 0.6),
                                   result.posed.vertices_m[np.ravel(result.posed.model.faces)]))
        return kit.new('visualization_msgs/msg/MarkerArray', markers=markers)

    def tf(self, result: TrackResult) -> Any:
        """``tf2_msgs/TFMessage``: every URDF joint's parent -> child transform."""
        kit = self.kit
        transforms = joint_transforms(self.joints, result.theta)
        quats = quaternions_xyzw_from_matrices(transforms[:, :3, :3])
        stamped = []
        for joint, T, (qx, qy, qz, qw) in zip(self.joints, transforms, quats):
            x, y, z = (float(v) for v in T[:3, 3])
            stamped.append(kit.new(
                'geometry_msgs/msg/TransformStamped',
                header=header(kit, result.stamp_ns, joint.parent), child_frame_id=joint.child,
                transform=kit.new(
                    'geometry_msgs/msg/Transform',
                    translation=kit.new('geometry_msgs/msg/Vector3', x=x, y=y, z=z),
                    rotation=kit.new('geometry_msgs/msg/Quaternion', x=float(qx), y=float(qy),
                                     z=float(qz), w=float(qw)))))
        return kit.new('tf2_msgs/msg/TFMessage', transforms=stamped)
