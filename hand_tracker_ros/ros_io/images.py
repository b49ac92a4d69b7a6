"""sensor_msgs/Image and CameraInfo <-> numpy, and our SalientPoints message.

The only place (with the nodes) where ROS image messages meet arrays. Decoding goes through
:func:`hand_tracker_ros.bags.image_codec.image_from_msg`, the one decoder of every path
(offline too), which reads rclpy messages as they are. Encoding writes the pixels with
``array.array.frombytes`` (one copy): assigning a numpy array to ``msg.data`` iterates element
by element and costs ~90 ms for a 640x480 image.
"""
from __future__ import annotations

import array
from collections.abc import Sequence

import numpy as np
from hand_tracker_msgs.msg import SalientPoint, SalientPoints
from rclpy.qos import QoSProfile, qos_profile_sensor_data
from sensor_msgs.msg import CameraInfo, CompressedImage, Image
from std_msgs.msg import Header

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.errors import CalibrationError
from hand_tracker_ros.vision.detections import SalientDetections

_ENCODINGS = {(np.dtype(np.uint8), 1): 'mono8', (np.dtype(np.uint8), 3): 'rgb8',
              (np.dtype(np.float32), 1): '32FC1', (np.dtype(np.float32), 2): '32FC2'}


def image_msg(pixels: np.ndarray, header: Header) -> Image:
    """Encode an (H, W) or (H, W, C) uint8/float32 array (mono8, rgb8, 32FC1, 32FC2)."""
    pixels = np.ascontiguousarray(pixels)
    channels = 1 if pixels.ndim == 2 else pixels.shape[2]
    encoding = _ENCODINGS[(pixels.dtype, channels)]
    msg = Image(header=header, height=pixels.shape[0], width=pixels.shape[1],
                encoding=encoding, is_bigendian=0,
                step=pixels.shape[1] * channels * pixels.dtype.itemsize)
    data = array.array('B')
    data.frombytes(pixels.view(np.uint8).ravel().data)
    msg.data = data
    return msg


def intrinsics_from_info(msg: CameraInfo, camera_name: str
                         ) -> tuple[int, int, FloatArray, FloatArray, str]:
    """(width, height, K (3, 3), D (N,), distortion_model) of a CameraInfo."""
    K = np.asarray(msg.k, np.float64).reshape(3, 3)
    if msg.width == 0 or msg.height == 0 or not np.all(np.isfinite(K)) or K[0, 0] <= 0:
        msg_text = f'{camera_name}: camera_info has no valid intrinsics (size or K)'
        raise CalibrationError(msg_text)
    return int(msg.width), int(msg.height), K, np.asarray(msg.d, np.float64), \
        msg.distortion_model


def salient_points_msg(tips: SalientDetections, header: Header, camera_name: str,
                       width: int, height: int,
                       labels: Sequence[int] | None = None) -> SalientPoints:
    """A SalientPoints message of one image's detections (labels default to unassigned)."""
    labels = [SalientPoint.LABEL_UNASSIGNED] * len(tips.score) if labels is None else labels
    points = [SalientPoint(u=float(u), v=float(v), score=float(s), label=int(lab))
              for (u, v), s, lab in zip(tips.uv_px, tips.score, labels)]
    return SalientPoints(header=header, camera_name=camera_name, width=width, height=height,
                         points=points)


def detections_from_msg(msg: SalientPoints) -> SalientDetections:
    """The detections of a SalientPoints message."""
    if not msg.points:
        return SalientDetections.empty()
    uv = np.array([(p.u, p.v) for p in msg.points], np.float64)
    score = np.array([p.score for p in msg.points], np.float64)
    return SalientDetections(uv, score)


def image_input(transport: str, image_topic: str) -> tuple[type, str]:
    """The message type and the topic (relative to a camera namespace) of a camera's images:
    ``sensor_msgs/Image`` on ``image_topic`` for ``raw``, ``sensor_msgs/CompressedImage`` on
    ``<image_topic>/compressed`` for ``compressed`` (image_transport's naming)."""
    if transport == 'raw':
        return Image, image_topic
    return CompressedImage, f'{image_topic}/compressed'


def sensor_qos(depth: int) -> QoSProfile:
    """Camera subscriptions: best effort (matches any publisher), keep the last ``depth``."""
    return QoSProfile(depth=depth, reliability=qos_profile_sensor_data.reliability,
                      history=qos_profile_sensor_data.history)
