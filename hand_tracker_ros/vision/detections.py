"""Unlabelled fingertip detections in one image: what the salient-point detector finds."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.checks import check_finite, check_shape


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
