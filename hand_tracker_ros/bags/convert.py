"""Conversions between plain values and rosbags message objects of ``sensor_msgs``/``std_msgs``.

Messages are instances of the classes of :func:`hand_tracker_ros.bags.typestore.typestore`
(rosbags dataclasses, not rclpy classes), so bags are written and read without ROS. The
readers accept any object with the same fields (e.g. a message decoded with a bag's own
type store). Time is always ``stamp_ns: int`` (nanoseconds since the epoch of the clock):
``stamp_ns = sec * 10**9 + nanosec``.

Images are decoded by :func:`hand_tracker_ros.bags.image_codec.image_from_msg`, the one
decoder of every path; this module only writes them (rgb8 ``Image`` or jpeg/png
``CompressedImage``).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from hand_tracker_ros._typing import FloatArray, IntArray, UInt8Array
from hand_tracker_ros.bags.image_codec import compress_rgb
from hand_tracker_ros.bags.typestore import typestore
from hand_tracker_ros.checks import check_finite, check_shape
from hand_tracker_ros.errors import ImageFormatError, ShapeError
from hand_tracker_ros.model.shape import HandShape

NS_PER_S = 1_000_000_000


def _types() -> Any:
    return typestore().types


def header_msg(stamp_ns: int, frame_id: str) -> Any:
    """Return a ``std_msgs/msg/Header`` for ``stamp_ns`` (int ns >= 0) and ``frame_id``."""
    if stamp_ns < 0:
        msg = f'`stamp_ns` must be >= 0, got {stamp_ns}'
        raise ValueError(msg)
    types = _types()
    sec, nanosec = divmod(int(stamp_ns), NS_PER_S)
    stamp = types['builtin_interfaces/msg/Time'](sec=sec, nanosec=nanosec)
    return types['std_msgs/msg/Header'](stamp=stamp, frame_id=frame_id)


def stamp_ns_of(header: Any) -> int:
    """Return the stamp of a ``std_msgs/msg/Header`` as int nanoseconds."""
    return int(header.stamp.sec) * NS_PER_S + int(header.stamp.nanosec)


def image_msg(rgb: UInt8Array, stamp_ns: int, frame_id: str) -> Any:
    """Return an rgb8 ``sensor_msgs/msg/Image`` (``step = 3 * width``, no padding).

    Parameters
    ----------
    rgb : (H, W, 3) uint8
        Image, RGB channel order.
    stamp_ns : int
        Header stamp, ns.
    frame_id : str
        The camera's optical frame.

    Returns
    -------
    sensor_msgs/msg/Image
        Its ``data`` is a view of ``rgb`` when ``rgb`` is C-contiguous (no copy; the bytes are
        copied when the message is serialized), so do not modify ``rgb`` before writing it.

    Raises
    ------
    ImageFormatError
        If ``rgb`` is not an (H, W, 3) uint8 array.
    """
    if rgb.dtype != np.uint8 or rgb.ndim != 3 or rgb.shape[2] != 3:
        msg = f'image for rgb8 must be (H, W, 3) uint8, got {rgb.shape} {rgb.dtype}'
        raise ImageFormatError(msg)
    height, width, _ = rgb.shape
    return _types()['sensor_msgs/msg/Image'](
        header=header_msg(stamp_ns, frame_id), height=height, width=width, encoding='rgb8',
        is_bigendian=0, step=3 * width, data=np.ascontiguousarray(rgb).reshape(-1))


def compressed_image_msg(rgb: UInt8Array, stamp_ns: int, frame_id: str, codec: str) -> Any:
    """Return a ``sensor_msgs/msg/CompressedImage`` of an RGB image.

    Parameters
    ----------
    rgb : (H, W, 3) uint8
        Image, RGB channel order.
    stamp_ns : int
        Header stamp, ns.
    frame_id : str
        The camera's optical frame.
    codec : str
        ``jpeg`` or ``png``; ``format`` is set as compressed_image_transport does
        (``'rgb8; jpeg compressed bgr8'``).
    """
    data, fmt = compress_rgb(rgb, codec)
    return _types()['sensor_msgs/msg/CompressedImage'](
        header=header_msg(stamp_ns, frame_id), format=fmt, data=data)


@dataclass(frozen=True, slots=True)
class CameraInfoValues:
    """The intrinsics carried by a ``sensor_msgs/msg/CameraInfo``.

    Attributes
    ----------
    stamp_ns : int
        Header stamp, ns.
    frame_id : str
        The camera's optical frame.
    width, height : int
        Image size, px.
    K : (3, 3) float64
        Camera matrix, px.
    D : (N,) float64
        Distortion coefficients (N = 5 for ``plumb_bob``: k1, k2, p1, p2, k3).
    distortion_model : str
        ``plumb_bob``, ``rational_polynomial``, ... (REP 104 names).
    """

    stamp_ns: int
    frame_id: str
    width: int
    height: int
    K: FloatArray
    D: FloatArray
    distortion_model: str


def camera_info_msg(info: CameraInfoValues) -> Any:
    """Return a ``sensor_msgs/msg/CameraInfo`` of a monocular camera.

    ``R`` is the identity and ``P = [K | 0]`` (no rectification, no stereo baseline).

    Raises
    ------
    ShapeError
        If ``K`` is not (3, 3), ``D`` is not 1-D, or either holds non-finite values.
    """
    K = np.asarray(info.K, dtype=np.float64)
    D = np.asarray(info.D, dtype=np.float64)
    check_shape('K', K, (3, 3))
    check_shape('D', D, (None,))
    check_finite('K', K)
    check_finite('D', D)
    types = _types()
    return types['sensor_msgs/msg/CameraInfo'](
        header=header_msg(info.stamp_ns, info.frame_id), height=info.height, width=info.width,
        distortion_model=info.distortion_model, d=D.copy(), k=K.reshape(-1).copy(),
        r=np.eye(3).reshape(-1), p=np.hstack([K, np.zeros((3, 1))]).reshape(-1),
        binning_x=0, binning_y=0,
        roi=types['sensor_msgs/msg/RegionOfInterest'](
            x_offset=0, y_offset=0, height=0, width=0, do_rectify=False))


def camera_info_from_msg(msg: Any) -> CameraInfoValues:
    """Return the intrinsics of a ``sensor_msgs/msg/CameraInfo`` (``R``, ``P`` are ignored)."""
    return CameraInfoValues(
        stamp_ns=stamp_ns_of(msg.header), frame_id=msg.header.frame_id, width=int(msg.width),
        height=int(msg.height), K=np.array(msg.k, dtype=np.float64).reshape(3, 3),
        D=np.array(msg.d, dtype=np.float64), distortion_model=msg.distortion_model)


def joint_state_msg(stamp_ns: int, names: Sequence[str], positions: FloatArray,
                    frame_id: str = '') -> Any:
    """Return a ``sensor_msgs/msg/JointState`` with positions only (empty velocity/effort).

    Parameters
    ----------
    names : sequence of str, length P
        Joint names (as in the hand URDF).
    positions : (P,) float64
        Joint positions, rad for revolute joints and m for prismatic ones.
    """
    positions = np.asarray(positions, dtype=np.float64)
    check_shape('positions', positions, (len(names),))
    empty = np.zeros(0, dtype=np.float64)
    return _types()['sensor_msgs/msg/JointState'](
        header=header_msg(stamp_ns, frame_id), name=list(names), position=positions.copy(),
        velocity=empty, effort=empty)


def joint_state_from_msg(msg: Any) -> tuple[int, tuple[str, ...], FloatArray]:
    """Return ``(stamp_ns, names, positions (P,) float64)`` of a ``sensor_msgs/msg/JointState``.

    Raises
    ------
    ShapeError
        If the message has a different number of names and positions.
    """
    positions = np.array(msg.position, dtype=np.float64)
    if positions.shape != (len(msg.name),):
        msg_text = f'JointState has {len(msg.name)} names but {positions.size} positions'
        raise ShapeError(msg_text)
    return stamp_ns_of(msg.header), tuple(msg.name), positions


def _points_msg(xyz_m: FloatArray) -> list[Any]:
    point = _types()['geometry_msgs/msg/Point']
    return [point(x=float(x), y=float(y), z=float(z)) for x, y, z in xyz_m]


def _points_array(points: Sequence[Any]) -> FloatArray:
    return np.array([(p.x, p.y, p.z) for p in points], dtype=np.float64).reshape(-1, 3)


@dataclass(frozen=True, slots=True)
class HandStateValues:
    """The fields of a ``hand_tracker_msgs/msg/HandState`` as plain values.

    Attributes
    ----------
    stamp_ns : int
        Stamp of the input frame set, ns.
    frame_id : str
        World frame of the estimate.
    status : int
        A :class:`~hand_tracker_ros.status.TrackStatus` value (the message's ``STATUS_*``).
    confidence : float
        Probability in [0, 1] that the estimate is right.
    joint_names : tuple of str, length P
    joint_positions : (P,) float64
        m for hand_tx/ty/tz, rad for rotations.
    keypoint_names : tuple of str, length J
    keypoints_m : (J, 3) float64
        3D keypoints in ``frame_id`` (J = 21 for the standard hand layout).
    fingertips_m : (5, 3) float64
        Thumb, index, middle, ring, pinky tips in ``frame_id``.
    shape_names : tuple of str, length S
    shape_parameters : (S,) float64
    energy_names : tuple of str, length E
    energy_costs : (E,) float64
    iterations : int
        LM iterations spent on the frame.
    processing_time_s : float
        Wall time from receipt of the input set to the estimate.
    """

    stamp_ns: int
    frame_id: str
    status: int
    confidence: float
    joint_names: tuple[str, ...]
    joint_positions: FloatArray
    keypoint_names: tuple[str, ...]
    keypoints_m: FloatArray
    fingertips_m: FloatArray
    shape_names: tuple[str, ...]
    shape_parameters: FloatArray
    energy_names: tuple[str, ...]
    energy_costs: FloatArray
    iterations: int
    processing_time_s: float

    @property
    def shape(self) -> HandShape:
        """The hand shape the estimate was posed with (``shape_parameters``; the session may
        have refined its scale while tracking)."""
        return HandShape.from_vector(self.shape_parameters)


def _check_hand_state(state: HandStateValues) -> None:
    check_shape('joint_positions', state.joint_positions, (len(state.joint_names),))
    check_shape('keypoints_m', state.keypoints_m, (len(state.keypoint_names), 3))
    check_shape('fingertips_m', state.fingertips_m, (5, 3))
    check_shape('shape_parameters', state.shape_parameters, (len(state.shape_names),))
    check_shape('energy_costs', state.energy_costs, (len(state.energy_names),))
    if state.status not in (0, 1, 2):
        msg = f'`status` must be 0, 1 or 2, got {state.status}'
        raise ValueError(msg)


def hand_state_msg(state: HandStateValues) -> Any:
    """Return a ``hand_tracker_msgs/msg/HandState``.

    Raises
    ------
    ShapeError
        If an array's length differs from its names' (or fingertips are not (5, 3)).
    """
    _check_hand_state(state)
    return _types()['hand_tracker_msgs/msg/HandState'](
        header=header_msg(state.stamp_ns, state.frame_id), status=int(state.status),
        confidence=float(state.confidence), joint_names=list(state.joint_names),
        joint_positions=np.array(state.joint_positions, dtype=np.float64),
        keypoint_names=list(state.keypoint_names), keypoints=_points_msg(state.keypoints_m),
        fingertips=_points_msg(state.fingertips_m), shape_names=list(state.shape_names),
        shape_parameters=np.array(state.shape_parameters, dtype=np.float64),
        energy_names=list(state.energy_names),
        energy_costs=np.array(state.energy_costs, dtype=np.float64),
        iterations=int(state.iterations), processing_time=float(state.processing_time_s))


def hand_state_from_msg(msg: Any) -> HandStateValues:
    """Return the plain values of a ``hand_tracker_msgs/msg/HandState``.

    Bags keep the definition they were recorded with: a HandState from before the
    ``confidence`` field gets NaN there.
    """
    return HandStateValues(
        stamp_ns=stamp_ns_of(msg.header), frame_id=msg.header.frame_id, status=int(msg.status),
        confidence=float(getattr(msg, 'confidence', math.nan)),
        joint_names=tuple(msg.joint_names),
        joint_positions=np.array(msg.joint_positions, dtype=np.float64),
        keypoint_names=tuple(msg.keypoint_names), keypoints_m=_points_array(msg.keypoints),
        fingertips_m=_points_array(msg.fingertips), shape_names=tuple(msg.shape_names),
        shape_parameters=np.array(msg.shape_parameters, dtype=np.float64),
        energy_names=tuple(msg.energy_names),
        energy_costs=np.array(msg.energy_costs, dtype=np.float64),
        iterations=int(msg.iterations), processing_time_s=float(msg.processing_time))


@dataclass(frozen=True, slots=True)
class SalientPointsValues:
    """The fields of a ``hand_tracker_msgs/msg/SalientPoints`` as plain values.

    Attributes
    ----------
    stamp_ns : int
        Stamp of the source image, ns.
    frame_id : str
        The camera's optical frame.
    camera_name : str
    width, height : int
        Size of the image the detections refer to, px.
    uv_px : (N, 2) float64
        Detections (u right, v down; origin at the centre of the top-left pixel).
    score : (N,) float64
        Confidence in [0, 1].
    label : (N,) int64
        Finger 0..4, or -1 unassigned.
    """

    stamp_ns: int
    frame_id: str
    camera_name: str
    width: int
    height: int
    uv_px: FloatArray
    score: FloatArray
    label: IntArray


def salient_points_msg(points: SalientPointsValues) -> Any:
    """Return a ``hand_tracker_msgs/msg/SalientPoints`` (u, v, score stored as float32).

    Raises
    ------
    ShapeError
        If ``uv_px`` is not (N, 2) or ``score``/``label`` are not (N,).
    """
    count = len(points.uv_px)
    check_shape('uv_px', points.uv_px, (count, 2))
    check_shape('score', points.score, (count,))
    check_shape('label', points.label, (count,))
    point = _types()['hand_tracker_msgs/msg/SalientPoint']
    items = [point(u=float(u), v=float(v), score=float(s), label=int(lab))
             for (u, v), s, lab in zip(points.uv_px, points.score, points.label)]
    return _types()['hand_tracker_msgs/msg/SalientPoints'](
        header=header_msg(points.stamp_ns, points.frame_id), camera_name=points.camera_name,
        width=int(points.width), height=int(points.height), points=items)


def salient_points_from_msg(msg: Any) -> SalientPointsValues:
    """Return the plain values of a ``hand_tracker_msgs/msg/SalientPoints``."""
    return SalientPointsValues(
        stamp_ns=stamp_ns_of(msg.header), frame_id=msg.header.frame_id,
        camera_name=msg.camera_name, width=int(msg.width), height=int(msg.height),
        uv_px=np.array([(p.u, p.v) for p in msg.points], dtype=np.float64).reshape(-1, 2),
        score=np.array([p.score for p in msg.points], dtype=np.float64),
        label=np.array([p.label for p in msg.points], dtype=np.int64))
