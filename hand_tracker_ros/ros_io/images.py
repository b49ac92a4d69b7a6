"""sensor_msgs/Image and CameraInfo <-> numpy, and our SalientPoints message.

The only place (with the nodes) where ROS image messages meet arrays. Decoding goes through
:func:`hand_tracker_ros.bags.image_codec.image_from_msg`, the one decoder of every path
(offline too), which reads rclpy messages as they are. Encoding writes the pixels with
``array.array.frombytes`` (one copy): assigning a numpy array to ``msg.data`` iterates element
by element and costs ~90 ms for a 640x480 image.
"""
from __future__ import annotations

import array
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np
from hand_tracker_msgs.msg import SalientPoint, SalientPoints
from rclpy.node import Node
from rclpy.qos import QoSProfile, qos_profile_sensor_data
from sensor_msgs.msg import CameraInfo, CompressedImage, Image
from std_msgs.msg import Header

from hand_tracker_ros._typing import FloatArray, UInt8Array
from hand_tracker_ros.bags.image_codec import image_from_msg
from hand_tracker_ros.errors import CalibrationError, HandTrackerError
from hand_tracker_ros.pipeline.live import NewestSetWorker
from hand_tracker_ros.sync.approximate import ApproximateTimeSync, SyncConfig, SyncedSet
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
    data.frombytes(pixels.view(np.uint8).ravel())
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


def stamp_ns_of(msg: Any) -> int:
    """The header stamp of a stamped message, in ns."""
    return msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec


def sensor_qos(depth: int) -> QoSProfile:
    """Camera subscriptions: best effort (matches any publisher), keep the last ``depth``."""
    return QoSProfile(depth=depth, reliability=qos_profile_sensor_data.reliability,
                      history=qos_profile_sensor_data.history)


@dataclass(frozen=True, eq=False)
class ImageSet:
    """One synchronized set of camera images, cameras in the node's order.

    Attributes
    ----------
    cameras : tuple of str
    images_rgb : tuple of (H, W, 3) uint8
    headers : tuple of std_msgs/Header
        The input messages' headers (stamps and frame ids to publish with).
    """

    cameras: tuple[str, ...]
    images_rgb: tuple[UInt8Array, ...]
    headers: tuple[Header, ...]


class ImageInputs:
    """Every camera's image and camera_info subscriptions; whole synchronized sets, decoded,
    on a worker thread, the newest first.

    Subscribes (sensor-data QoS) to ``<cam>/<image_topic>`` (``sensor_msgs/Image``) or, with
    ``transport='compressed'``, to ``<cam>/<image_topic>/compressed``
    (``sensor_msgs/CompressedImage``, image_transport's naming), and to ``<cam>/camera_info``,
    whose latest valid size each decoded image must have. Image messages are grouped by
    stamp (:mod:`hand_tracker_ros.sync.approximate`, ``slop_ms``); each complete set goes to a
    :class:`~hand_tracker_ros.pipeline.live.NewestSetWorker`, which decodes it and calls
    ``on_set``: a node that falls behind drops whole sets, and the sets it serves line up
    across cameras. A set with an image that cannot be decoded is dropped with a throttled
    error.

    Parameters
    ----------
    node : rclpy.node.Node
        The node that owns the subscriptions and logs errors (throttled).
    cameras : sequence of str
        Camera namespaces.
    image_topic : str
        Image topic relative to each camera namespace.
    transport : str
        ``raw`` or ``compressed``.
    depth : int
        Queue depth per subscription.
    on_set : callable
        Called with each :class:`ImageSet` (on the worker thread).
    throttle_s : float
        Minimum period of repeated errors, s.
    slop_ms : float
        Largest stamp spread within one set, ms.
    """

    def __init__(self, node: Node, cameras: Sequence[str], image_topic: str, transport: str,
                 depth: int, on_set: Callable[[ImageSet], None], throttle_s: float,
                 slop_ms: float) -> None:
        self._node = node
        self._throttle_s = throttle_s
        self._cameras = tuple(cameras)
        self._on_set = on_set
        self._sizes: dict[str, tuple[int, int]] = {}
        self._sync = ApproximateTimeSync(self._cameras, SyncConfig(slop_ns=round(slop_ms * 1e6)))
        self._worker: NewestSetWorker[SyncedSet] = NewestSetWorker(
            self._decode_set, self._on_error, f'{node.get_name()}-sets')
        qos = sensor_qos(depth)
        msg_type, suffix = (Image, '') if transport == 'raw' else (CompressedImage, '/compressed')
        for cam in self._cameras:
            node.create_subscription(msg_type, f'{cam}/{image_topic}{suffix}',
                                     partial(self._on_image, cam), qos)
            node.create_subscription(CameraInfo, f'{cam}/camera_info',
                                     partial(self._on_info, cam), qos)

    @property
    def skipped(self) -> int:
        """Complete sets a newer one replaced before the worker was free."""
        return self._worker.skipped

    def close(self) -> None:
        """Stop the worker thread (the set in progress is finished)."""
        self._worker.close()

    def _on_image(self, camera: str, msg: Image | CompressedImage) -> None:
        """(Executor thread.) One camera's image into the synchronizer."""
        for synced in self._sync.add(camera, stamp_ns_of(msg), msg):
            self._worker.offer(synced)

    def _on_info(self, camera: str, msg: CameraInfo) -> None:
        """camera_info callback; an invalid one is logged (throttled) and ignored."""
        try:
            width, height, *_ = intrinsics_from_info(msg, camera)
        except HandTrackerError as err:
            self._node.get_logger().error(str(err), throttle_duration_sec=self._throttle_s)
            return
        self._sizes[camera] = (width, height)

    def _decode_set(self, synced: SyncedSet) -> None:
        msgs = [synced.items[c] for c in self._cameras]
        images = tuple(image_from_msg(m, source=c, expected_size_px=self._sizes.get(c))
                       for c, m in zip(self._cameras, msgs))
        self._on_set(ImageSet(self._cameras, images, tuple(m.header for m in msgs)))

    def _on_error(self, err: BaseException) -> None:
        kind = '' if isinstance(err, HandTrackerError) else f' ({type(err).__name__})'
        self._node.get_logger().error(f'dropping a set{kind}: {err}',
                                      throttle_duration_sec=self._throttle_s)
