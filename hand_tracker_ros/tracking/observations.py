"""What one synchronized set of camera frames tells the tracker (plain data, no ROS)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.checks import check_finite, check_shape
from hand_tracker_ros.geometry.camera import PinholeCamera
from hand_tracker_ros.vision.features import CameraFeatures


@dataclass(frozen=True, eq=False)
class SalientDetections:
    """Unlabelled fingertip candidates in one image.

    Attributes
    ----------
    uv_px : (N, 2) float64
        Pixel coordinates (u right, v down; pixel centres at integers).
    score : (N,) float64
        Detector confidence in [0, 1].
    """

    uv_px: FloatArray
    score: FloatArray

    def __post_init__(self) -> None:
        check_shape('uv_px', self.uv_px, (None, 2))
        check_shape('score', self.score, (self.uv_px.shape[0],))
        check_finite('uv_px', self.uv_px)

    @classmethod
    def empty(cls) -> SalientDetections:
        """No detections."""
        return cls(np.zeros((0, 2)), np.zeros(0))


@dataclass(frozen=True, eq=False)
class CameraObservation:
    """One camera's calibration, image features and fingertip detections for one frame."""

    camera: PinholeCamera
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
