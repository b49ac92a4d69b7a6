"""Find the hand from the observations alone: first frame and recovery after divergence.

1. **Where**: each camera's foreground mask gives a centroid ``c_i``; its camera ray
   ``o_i + s d_i`` passes near the hand. The hand centre is the least-squares point closest to
   all rays, ``x = argmin sum_i |(I - d_i d_i^T)(x - o_i)|^2``, i.e. the solution of
   ``(sum_i P_i) x = sum_i P_i o_i`` with ``P_i = I - d_i d_i^T``.
2. **How oriented**: hypotheses of the relaxed hand centred there, rotated over a grid of
   roll (about the finger axis) and pitch angles, are scored by the mean silhouette IoU of the
   rendered model with the observed masks (:func:`.evidence.silhouette_iou`).
3. **Refine**: the ``keep`` best hypotheses get ``quick_passes`` short fits (one round,
   :data:`.schedule.QUICK`) and are ranked by the caller's ``score`` (the tracking session
   passes its confidence, :mod:`.evidence`; the default is the silhouette IoU); the
   ``refine_best`` best of them get ``refine_frames`` full fits, and the best score wins. The
   ranking of the unfitted relaxed hands by IoU is weak (on a random-motion frame the
   hypothesis that ends within 15 mm ranked 11th of 48), hence the short fits of many.

Cost: 48 short fits and 18 full fits with the defaults, a few seconds on a 2-core machine.
"""
from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.config import param
from hand_tracker_ros.errors import HandTrackerError
from hand_tracker_ros.geometry.camera import PinholeCamera
from hand_tracker_ros.model.layout import Layout
from hand_tracker_ros.synthetic.motions import RELAXED_DEG
from hand_tracker_ros.tracking.evidence import silhouette_iou
from hand_tracker_ros.tracking.observations import FrameObservations
from hand_tracker_ros.tracking.schedule import QUICK, Round
from hand_tracker_ros.tracking.tracker import Fit, HandTracker

LOG = logging.getLogger(__name__)


@dataclass(frozen=True)
class InitConfig:
    """Hypotheses and refinement of the observation-based initialization."""

    roll_steps: int = param(16, 'hypotheses about the finger axis (360 deg / steps)', low=1,
                            high=72)
    pitches_deg: tuple[float, ...] = param((-60.0, 0.0, 60.0), 'hypotheses of wrist pitch',
                                           unit='deg')
    keep: int = param(24, 'hypotheses (best silhouette IoU first) given short fits',
                      low=1, high=500)
    quick_passes: int = param(2, 'short fits (one round) per kept hypothesis', low=1, high=50)
    refine_best: int = param(3, 'hypotheses (best score after the short fits) refined',
                             low=1, high=50)
    refine_frames: int = param(6, 'full fits per refined hypothesis', low=1, high=50)
    min_mask_px: int = param(50, 'masks smaller than this are ignored', unit='px', low=1)


def triangulate_mask_centroids(cameras: Sequence[PinholeCamera],
                               masks: Sequence[np.ndarray], min_px: int) -> FloatArray:
    """The world point closest to the rays through the mask centroids (m), shape (3,)."""
    A, b = np.zeros((3, 3)), np.zeros(3)
    used = 0
    for camera, mask in zip(cameras, masks):
        vv, uu = np.nonzero(mask)
        if uu.size < min_px:
            continue
        origin, direction = camera.rays(np.array([[uu.mean(), vv.mean()]]))
        P = np.eye(3) - np.outer(direction[0], direction[0])
        A += P
        b += P @ origin
        used += 1
    if used < 2:
        msg = f'cannot place the hand: only {used} camera(s) see a foreground region'
        raise HandTrackerError(msg)
    return np.linalg.solve(A, b)


def hypotheses(model, center_m: FloatArray, config: InitConfig) -> list[FloatArray]:  # noqa: ANN001
    """Relaxed hands centred on ``center_m`` over the roll x pitch grid."""
    relaxed = np.zeros(Layout.P)
    for name, deg in RELAXED_DEG.items():
        relaxed[Layout.index(name)] = np.deg2rad(deg)
    out = []
    for roll in np.linspace(0.0, 2.0 * np.pi, config.roll_steps, endpoint=False):
        for pitch in np.deg2rad(config.pitches_deg):
            theta = relaxed.copy()
            theta[Layout.index('hand_ry')] = roll
            theta[Layout.index('hand_rx')] = pitch
            centre = model.pose(theta, jacobian=False).keypoints_m.mean(axis=0)
            theta[Layout.translation] = center_m - centre
            out.append(np.clip(theta, model.lower, model.upper))
    return out


def initialize(tracker: HandTracker, observations: FrameObservations,
               config: InitConfig = InitConfig(),
               score: Callable[[Fit], float] | None = None) -> FloatArray:
    """A pose of the hand seen in ``observations``; leaves ``tracker`` reset to it.

    ``score`` ranks the refined hypotheses (higher is better); by default the silhouette IoU.
    """
    masks = [c.features.mask for c in observations.cameras]
    center = triangulate_mask_centroids(tracker.cameras, masks, config.min_mask_px)
    scored = []
    for theta in hypotheses(tracker.model, center, config):
        views = tracker.views(tracker.model.pose(theta, jacobian=False))
        scored.append((silhouette_iou(views, observations), theta))
    scored.sort(key=lambda item: -item[0])
    if score is None:
        def score(fit: Fit) -> float:
            return silhouette_iou(fit.views, observations)

    def refined(theta: FloatArray, passes: int, plan: tuple[Round, ...] | None) -> Fit:
        tracker.reset(theta)
        for _ in range(passes):
            fit = tracker.fit(observations, plan=plan, separate=plan is None)
            tracker.reset(fit.theta)
        return fit

    quick = [refined(theta, config.quick_passes, QUICK) for _, theta in scored[:config.keep]]
    quick.sort(key=lambda fit: -score(fit))
    finals = [refined(fit.theta, config.refine_frames, None) for fit in quick[:config.refine_best]]
    best_score, best = max(((score(fit), fit.theta) for fit in finals), key=lambda item: item[0])
    LOG.info('initialized at %s (score %.2f)', np.round(center, 3), best_score)
    tracker.reset(best)
    return best
