"""Precision, recall and localisation error of fingertip detections against ground truth.

Matching per view is greedy by score: each detection, highest score first, is a true
positive if an unmatched *visible* tip lies within ``radius_px``; it takes the nearest such
tip. A detection that is not a true positive but lies within ``radius_px`` of an *invisible*
tip's projection (an occluded or self-occluded tip the image may still suggest) counts as
neither true nor false positive; every other detection is a false positive.

``precision = TP / (TP + FP)``, ``recall = matched visible tips / visible tips``, and the
localisation error is the pixel distance of each true positive to its tip.
"""
from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np

from hand_tracker_ros._typing import BoolArray, FloatArray
from hand_tracker_ros.vision.detections import SalientDetections


@dataclass
class DetectionTally:
    """Running counts over views (mutable accumulator; read the properties at the end)."""

    true_positives: int = 0
    false_positives: int = 0
    ignored: int = 0
    visible_tips: int = 0
    errors_px: list[float] = field(default_factory=list)

    @property
    def precision(self) -> float:
        """TP / (TP + FP); 1 when there were no detections."""
        total = self.true_positives + self.false_positives
        return self.true_positives / total if total else 1.0

    @property
    def recall(self) -> float:
        """Matched visible tips / visible tips; 1 when there were none."""
        return self.true_positives / self.visible_tips if self.visible_tips else 1.0

    def add(self, detections: SalientDetections, tips_uv: FloatArray,
            tips_visible: BoolArray, radius_px: float = 8.0) -> BoolArray:
        """Match one view's detections (see the module docstring) and count.

        Parameters
        ----------
        detections : SalientDetections
        tips_uv : (5, 2) float64
            Ground-truth tip projections (NaN allowed for invisible tips).
        tips_visible : (5,) bool
        radius_px : float

        Returns
        -------
        found : (5,) bool
            The visible tips a detection was matched to.
        """
        tips = np.nan_to_num(np.asarray(tips_uv, dtype=np.float64), nan=-1e9)
        visible = np.asarray(tips_visible, dtype=bool)
        self.visible_tips += int(visible.sum())
        free = visible.copy()
        for k in np.argsort(-detections.score, kind='stable'):
            dist = np.linalg.norm(tips - detections.uv_px[k], axis=1)
            candidates = np.flatnonzero(free & (dist <= radius_px))
            if candidates.size:
                best = candidates[np.argmin(dist[candidates])]
                free[best] = False
                self.true_positives += 1
                self.errors_px.append(float(dist[best]))
            elif np.any(~visible & (dist <= radius_px)):
                self.ignored += 1
            else:
                self.false_positives += 1
        return visible & ~free

    def error_percentiles(self, qs: Iterable[float] = (50.0, 90.0)) -> FloatArray:
        """Percentiles of the localisation error of the true positives (px)."""
        if not self.errors_px:
            return np.full(len(tuple(qs)), np.nan)
        return np.percentile(self.errors_px, list(qs))
