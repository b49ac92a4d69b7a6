"""Is the estimate still on the hand? Silhouette agreement between model and observations.

For every camera the rendered model mask ``M`` is compared with the observed foreground mask
``O`` (from :mod:`hand_tracker_ros.vision.mask`):

- **coverage** ``|M & O| / |M|``, the fraction of the model silhouette that lies on observed
  foreground, decides whether a frame is lost. A diverged fit, or a hand that left the views,
  drives it towards 0, while skin-coloured clutter elsewhere in the image (which enlarges
  ``O``) cannot lower it;
- **IoU** ``|M & O| / |M | O|`` ranks initialization hypotheses, where a model that covers
  only part of the hand must lose against one that explains all of it.

Both are averaged over the cameras where they are defined (non-empty ``M``, or union).
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

    min_coverage: float = param(0.6, 'mean fraction of the model silhouette on observed '
                                'foreground below which the frame is lost', low=0.0, high=1.0)
    reinit_after: int = param(3, 'consecutive lost frames before re-initialization',
                              low=1, high=1000)


def silhouette_coverage(views: Sequence[ModelView], observations: FrameObservations) -> float:
    """Mean fraction of the model silhouette on observed foreground (0 if nothing is seen)."""
    values = []
    for view, obs in zip(views, observations.cameras):
        model_px = np.count_nonzero(view.raster.mask)
        if model_px:
            values.append(np.count_nonzero(view.raster.mask & obs.features.mask) / model_px)
    return float(np.mean(values)) if values else 0.0


def silhouette_iou(views: Sequence[ModelView], observations: FrameObservations) -> float:
    """Mean IoU of the model's and the observed masks over the cameras (0 if none overlap)."""
    ious = []
    for view, obs in zip(views, observations.cameras):
        model_mask, observed = view.raster.mask, obs.features.mask
        union = np.count_nonzero(model_mask | observed)
        if union:
            ious.append(np.count_nonzero(model_mask & observed) / union)
    return float(np.mean(ious)) if ious else 0.0
