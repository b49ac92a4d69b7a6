"""What one synchronized set of camera frames tells the tracker (plain data, no ROS)."""
from __future__ import annotations

from dataclasses import dataclass

from hand_tracker_ros.geometry.camera_model import Camera
from hand_tracker_ros.vision.detections import SalientDetections
from hand_tracker_ros.vision.features import CameraFeatures


@dataclass(frozen=True, eq=False)
class CameraObservation:
    """One camera's calibration, image features and fingertip detections for one frame."""

    camera: Camera
    features: CameraFeatures
    tips: SalientDetections


@dataclass(frozen=True, eq=False)
class FrameObservations:
    """A synchronized set of C camera observations.

    Attributes
    ----------
    stamp_ns : int
        Reference stamp of the set (ns).
    cameras : tuple of CameraObservation
        One entry per camera of the rig, in rig order.
    """

    stamp_ns: int
    cameras: tuple[CameraObservation, ...]
