"""Is the estimate still on the hand? Silhouette agreement between model and observations.

For every camera the rendered model mask ``M`` is compared with the observed foreground mask
``O`` (from :mod:`hand_tracker_ros.vision.mask`) by intersection over union,
``IoU = |M & O| / |M | O|``; the mean over cameras with a non-empty union measures agreement.
A diverged fit, or a hand that left the views, drives it towards 0.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from hand_tracker_ros.config import param
from hand_tracker_ros.tracking.observations import FrameObservations
from hand_tracker_ros.tracking.views import ModelView


@dataclass(frozen=True)
class FailureConfig:
    """When a frame counts as lost, and when to re-initialize."""

    min_iou: float = param(0.35, 'mean model/observed silhouette IoU below which the frame '
                           'is lost', low=0.0, high=1.0)
    reinit_after: int = param(3, 'consecutive lost frames before re-initialization',
                              low=1, high=1000)


def silhouette_agreement(views: Sequence[ModelView], observations: FrameObservations) -> float:
    """Mean IoU of the model's and the observed masks over the cameras (0 if none overlap)."""
    ious = []
    for view, obs in zip(views, observations.cameras):
        model_mask, observed = view.raster.mask, obs.features.mask
        union = np.count_nonzero(model_mask | observed)
        if union:
            ious.append(np.count_nonzero(model_mask & observed) / union)
    return float(np.mean(ious)) if ious else 0.0
