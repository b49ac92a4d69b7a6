"""Accuracy metrics of a tracked sequence against ground truth.

Per frame ``t`` with estimated and true 3D keypoints ``x_tj, y_tj`` (J = 21, world frame):

- 3D joint error ``e_t = (1/J) sum_j |x_tj - y_tj|`` (mm); the sequence reports the mean,
  median, 95th percentile and maximum of ``e_t`` over frames;
- fingertip error: the same over the 5 tip keypoints only (mm);
- 2D reprojection error: ``(1/(C J)) sum_c sum_j |pi_c(x_tj) - pi_c(y_tj)|`` (px), the mean
  image distance of the projected keypoints over the C cameras;
- tracking failures: frames the tracker reported LOST, plus frames with ``e_t`` above
  ``failure_mm`` (15 mm) although reported as tracking;
- interpenetration: the largest depth (mm) a mesh vertex reaches inside a non-adjacent part
  of the estimated hand (``geometry.triangle_pairs.max_interpenetration_m``), max over frames.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.geometry.camera_model import Camera
from hand_tracker_ros.geometry.triangle_pairs import face_parts, max_interpenetration_m
from hand_tracker_ros.model.hand import PosedHand
from hand_tracker_ros.model.skeleton import KEYPOINT_NAMES

TIP_INDICES = tuple(i for i, name in enumerate(KEYPOINT_NAMES) if name.endswith('_tip'))
FAILURE_MM = 15.0


@dataclass(frozen=True)
class SequenceScores:
    """Summary of one tracked sequence (lengths in mm, image errors in px, time in ms)."""

    frames: int
    joint_mean_mm: float
    joint_median_mm: float
    joint_p95_mm: float
    joint_max_mm: float
    fingertip_mean_mm: float
    reprojection_px: float
    max_interpenetration_mm: float
    failures: int
    ms_per_frame: float

    def as_dict(self) -> dict[str, float]:
        """Plain dict (for JSON)."""
        return asdict(self)


def joint_errors_mm(estimated_m: FloatArray, truth_m: FloatArray) -> FloatArray:
    """Per-frame mean keypoint distance, ``(T, J, 3)`` x2 -> ``(T,)`` mm."""
    return 1e3 * np.linalg.norm(estimated_m - truth_m, axis=-1).mean(axis=-1)


def reprojection_px(estimated_m: FloatArray, truth_m: FloatArray,
                    cameras: Sequence[Camera]) -> FloatArray:
    """Per-frame mean image distance of projected keypoints, ``(T, J, 3)`` x2 -> ``(T,)``."""
    t, j, _ = estimated_m.shape
    errors = []
    for camera in cameras:
        uv_est, _ = camera.project(estimated_m.reshape(-1, 3))
        uv_true, _ = camera.project(truth_m.reshape(-1, 3))
        errors.append(np.linalg.norm(uv_est - uv_true, axis=-1).reshape(t, j).mean(axis=1))
    return np.mean(errors, axis=0)


def score_sequence(estimated_m: FloatArray, truth_m: FloatArray, lost: Sequence[bool],
                   cameras: Sequence[Camera], interpenetration_m: Sequence[float],
                   seconds_per_frame: Sequence[float]) -> SequenceScores:
    """Summarise a tracked sequence.

    Parameters
    ----------
    estimated_m, truth_m : (T, J, 3) float64
        Estimated and true keypoints per frame (world frame, m).
    lost : (T,) bool
        Frames the tracker reported as lost.
    cameras : sequence of Camera
        The rig, for the reprojection error.
    interpenetration_m : (T,) float
        Largest interpenetration depth of the estimated mesh per frame (m).
    seconds_per_frame : (T,) float
        Processing time per frame (s).
    """
    errors = joint_errors_mm(estimated_m, truth_m)
    tips = joint_errors_mm(estimated_m[:, TIP_INDICES], truth_m[:, TIP_INDICES])
    lost_arr = np.asarray(lost, bool)
    failures = int(np.count_nonzero(lost_arr | (errors > FAILURE_MM)))
    return SequenceScores(
        frames=int(errors.size), joint_mean_mm=float(errors.mean()),
        joint_median_mm=float(np.median(errors)),
        joint_p95_mm=float(np.percentile(errors, 95)), joint_max_mm=float(errors.max()),
        fingertip_mean_mm=float(tips.mean()),
        reprojection_px=float(reprojection_px(estimated_m, truth_m, cameras).mean()),
        max_interpenetration_mm=1e3 * float(np.max(interpenetration_m, initial=0.0)),
        failures=failures, ms_per_frame=1e3 * float(np.median(seconds_per_frame)))


def deepest_interpenetration_m(posed: PosedHand) -> float:
    """Deepest interpenetration (m) between non-adjacent parts of the hand ``posed``, on
    its own model (the session may have rebuilt the model at another scale)."""
    model = posed.model
    return max_interpenetration_m(posed.vertices_m, model.faces,
                                  face_parts(model.faces, model.vertex_part),
                                  model.adjacent_parts)
