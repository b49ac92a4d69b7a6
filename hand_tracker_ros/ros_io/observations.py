"""The `features` / `salient_points` topics of one camera -> the tracker's CameraObservation.

Per camera the tracker receives five topics with the camera image's stamp: ``edges`` (mono8,
255 on edges), ``edge_orientation`` (32FC1, edge-normal direction, rad), ``mask`` (mono8, 255
on the hand), ``flow`` (32FC2, px from the previous frame, NaN where there is none; absent on
a camera's first frame) and ``salient_points`` (absent when no detector runs).

Frame assembly (:class:`FrameAssembler`, one per camera)
--------------------------------------------------------
Messages are grouped by exact stamp (they all copy the image header). ``edges``,
``edge_orientation`` and ``mask`` are *required*; ``flow`` and ``salient_points`` are
*optional*. A frame is released

- at once when every part has arrived;
- when the required parts are in and ``wait_s`` has passed since the last of them arrived
  (checked by :meth:`FrameAssembler.expire`, which the node calls from a fast timer),
  if an optional part is still missing. The tracker then runs without it (no flow term for
  that camera, or no fingertip detections);
- an optional part that has never been received on this camera is not waited for at all, so
  a graph without a detector (or a camera's first frames before flow exists) costs no latency.

Released frames are counted ``frames``, those released by the wait ``timed_out``. At most
``max_pending`` incomplete frames are kept per camera; the oldest is dropped beyond that
(counted ``dropped``). A part for a stamp already released is counted ``late`` and
ignored. :func:`camera_observation` (the tracker's view of a frame) runs on the tracker's
processing thread, not in the ROS callbacks.
"""
from __future__ import annotations

from collections import Counter, deque
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from hand_tracker_msgs.msg import SalientPoints
from sensor_msgs.msg import Image

from hand_tracker_ros._typing import BoolArray, Float32Array
from hand_tracker_ros.core.observations import CameraObservation, FrameObservations
from hand_tracker_ros.errors import ImageFormatError, ShapeError
from hand_tracker_ros.geometry.camera_model import Camera
from hand_tracker_ros.ros_io.images import detections_from_msg
from hand_tracker_ros.vision.detections import SalientDetections
from hand_tracker_ros.vision.edges import EdgeMap
from hand_tracker_ros.vision.features import CameraFeatures
from hand_tracker_ros.vision.flow import DenseFlow

REQUIRED = ('edges', 'edge_orientation', 'mask')
OPTIONAL = ('flow', 'salient_points')
PARTS = REQUIRED + OPTIONAL
# topic -> (encoding, channels, dtype) of the feature images the `features` node publishes.
IMAGE_LAYOUTS = {'edges': ('mono8', 1, np.uint8), 'edge_orientation': ('32FC1', 1, np.float32),
                 'mask': ('mono8', 1, np.uint8), 'flow': ('32FC2', 2, np.float32)}


def feature_image(msg: Image, camera_name: str, topic: str,
                  size_px: tuple[int, int]) -> np.ndarray:
    """Decode one feature image, checking encoding, size, step and buffer length.

    Parameters
    ----------
    msg : sensor_msgs/Image
    camera_name, topic : str
        Used in error messages; ``topic`` selects the expected layout (:data:`IMAGE_LAYOUTS`).
    size_px : (int, int)
        ``(width, height)`` of the camera at the tracker's working resolution (the rig's
        size scaled down to ``working_width_px``).

    Returns
    -------
    pixels : (H, W) uint8 or float32, or (H, W, 2) float32
        A copy in native byte order.

    Raises
    ------
    ImageFormatError
        Wrong encoding or size, inconsistent step/buffer, or non-finite edge orientations
        (NaN flow is allowed: it marks pixels without flow).
    """
    encoding, channels, dtype = IMAGE_LAYOUTS[topic]
    where = f'{camera_name}/{topic}'
    if msg.encoding != encoding:
        msg_text = f'{where}: expected encoding {encoding}, got {msg.encoding!r}'
        raise ImageFormatError(msg_text)
    if (msg.width, msg.height) != tuple(size_px):
        msg_text = (f'{where}: image is {msg.width}x{msg.height} but the tracker works at '
                    f'{size_px[0]}x{size_px[1]} (the rig at working_width_px: the '
                    'features and salient_points nodes need the same working_width_px)')
        raise ImageFormatError(msg_text)
    item = np.dtype(dtype).newbyteorder('>' if msg.is_bigendian else '<')
    row_bytes = msg.width * channels * item.itemsize
    buf = np.frombuffer(msg.data, dtype=np.uint8)
    if msg.step < row_bytes or buf.size != msg.height * msg.step:
        msg_text = (f'{where}: step {msg.step} and {buf.size} data bytes do not fit '
                    f'{msg.width}x{msg.height} {encoding} ({row_bytes} bytes per row)')
        raise ImageFormatError(msg_text)
    rows = buf.reshape(msg.height, msg.step)[:, :row_bytes]
    pixels = np.ascontiguousarray(rows).view(item).astype(dtype)
    pixels = pixels.reshape((msg.height, msg.width, channels)).squeeze(axis=2) \
        if channels == 1 else pixels.reshape(msg.height, msg.width, channels)
    if topic == 'edge_orientation' and not np.all(np.isfinite(pixels)):
        msg_text = f'{where}: {int(np.count_nonzero(~np.isfinite(pixels)))} non-finite values'
        raise ImageFormatError(msg_text)
    return pixels


def part_value(msg: Image | SalientPoints, camera_name: str, topic: str,
               size_px: tuple[int, int]) -> Any:
    """The assembler value of one message: a decoded array, or detections for salient points.

    Raises
    ------
    ImageFormatError
        For a bad feature image (see :func:`feature_image`), or salient points of an image
        of another size than ``size_px``.
    ShapeError
        For salient points with non-finite coordinates.
    """
    if topic == 'salient_points':
        if (msg.width, msg.height) != tuple(size_px):
            msg_text = (f'{camera_name}/{topic}: detections in a {msg.width}x{msg.height} '
                        f'image but the tracker works at {size_px[0]}x{size_px[1]} (the '
                        'salient_points node needs the tracker\'s working_width_px)')
            raise ImageFormatError(msg_text)
        try:
            return detections_from_msg(msg)
        except ShapeError as err:
            msg_text = f'{camera_name}/{topic}: {err}'
            raise ShapeError(msg_text) from err
    pixels = feature_image(msg, camera_name, topic, size_px)
    return pixels > 0 if topic in ('edges', 'mask') else pixels


@dataclass(frozen=True, eq=False)
class CameraFrame:
    """The feature images and detections of one camera image.

    Attributes
    ----------
    camera_name : str
    stamp_ns : int
    edges : (H, W) bool
    orientation_rad : (H, W) float32
    mask : (H, W) bool
    flow_px : (H, W, 2) float32 or None
        NaN where there is no flow; None when no flow arrived (first frame, or waited out).
    tips : SalientDetections or None
        None when no salient points arrived.
    """

    camera_name: str
    stamp_ns: int
    edges: BoolArray
    orientation_rad: Float32Array
    mask: BoolArray
    flow_px: Float32Array | None
    tips: SalientDetections | None


class FrameAssembler:
    """Group one camera's feature messages by stamp into CameraFrames (module docstring).

    Parameters
    ----------
    camera_name : str
    wait_s : float
        How long a frame with its required parts waits for the optional ones (s).
    max_pending : int
        Incomplete frames kept (>= 1).
    """

    def __init__(self, camera_name: str, wait_s: float, max_pending: int) -> None:
        self.camera_name = camera_name
        self.wait_s = wait_s
        self.max_pending = max_pending
        self._pending: dict[int, dict[str, Any]] = {}
        self._ready_since: dict[int, float] = {}
        self._released: deque[int] = deque(maxlen=4 * max_pending)
        self._seen: set[str] = set()
        self.counts = Counter({'frames': 0, 'timed_out': 0, 'dropped': 0, 'late': 0})

    def add(self, part: str, stamp_ns: int, value: Any, now_s: float) -> CameraFrame | None:
        """Store one part (a value of :func:`part_value`); return the frame it completes."""
        self._seen.add(part)
        if stamp_ns in self._released:
            self.counts['late'] += 1
            return None
        parts = self._pending.setdefault(stamp_ns, {})
        parts[part] = value
        if len(self._pending) > self.max_pending:
            oldest = min(self._pending)
            del self._pending[oldest]
            self._ready_since.pop(oldest, None)
            self.counts['dropped'] += 1
        if stamp_ns not in self._pending or not all(p in parts for p in REQUIRED):
            return None
        self._ready_since.setdefault(stamp_ns, now_s)
        if all(p in parts or p not in self._seen for p in OPTIONAL):
            return self._release(stamp_ns)
        return None

    def expire(self, now_s: float) -> list[CameraFrame]:
        """Frames whose wait for optional parts is over, oldest first."""
        due = sorted(s for s, t in self._ready_since.items() if now_s - t >= self.wait_s)
        self.counts['timed_out'] += len(due)
        return [self._release(s) for s in due]

    def _release(self, stamp_ns: int) -> CameraFrame:
        parts = self._pending.pop(stamp_ns)
        self._ready_since.pop(stamp_ns, None)
        self._released.append(stamp_ns)
        self.counts['frames'] += 1
        return CameraFrame(self.camera_name, stamp_ns, parts['edges'],
                           parts['edge_orientation'], parts['mask'], parts.get('flow'),
                           parts.get('salient_points'))


def camera_observation(frame: CameraFrame, camera: Camera) -> CameraObservation:
    """The tracker's view of one camera frame."""
    size = (camera.width, camera.height)
    edges = EdgeMap(frame.edges, frame.orientation_rad)
    flow = None if frame.flow_px is None else DenseFlow(frame.flow_px)
    features = CameraFeatures(camera_name=camera.name, stamp_ns=frame.stamp_ns, edges=edges,
                              mask=frame.mask, flow=flow, gray=None,
                              roi_px=(0, 0, *size), image_size_px=size)
    tips = frame.tips if frame.tips is not None else SalientDetections.empty()
    return CameraObservation(camera, features, tips)


def frame_observations(stamp_ns: int, frames: Mapping[str, CameraFrame],
                       cameras: Sequence[Camera]) -> FrameObservations:
    """A synchronized set of camera frames (name -> frame) as FrameObservations, rig order."""
    return FrameObservations(stamp_ns, tuple(camera_observation(frames[c.name], c)
                                             for c in cameras))
