"""Find the hand from the observations alone: first frame and recovery after divergence.

1. **Where**: the centre and the longest principal axis of the visual hull of the
   foreground masks (:class:`VisualHull`, :class:`HandRegion`).
2. **How oriented**: hypotheses of the relaxed hand centred there, rotated over a grid of
   roll (about the finger axis) and pitch angles, are ranked by the mean silhouette IoU of
   the model with the observed masks, on a coarse grid with the model's vertices splatted
   (:class:`.evidence.CoarseMasks`; ``bench/bench_ranking.py``: rendering the 48
   hypotheses took 140-170 ms at 4 x 320x240 and 250-265 ms at 4 x 640x480, the splat 35-48
   ms, with rankings of Spearman correlation 0.97-0.98). The ``slide_best`` best are then
   slid along the hull's axis by ``slide_mm`` and keep the place of highest IoU (48 more
   splats: ranking a 4 x 320x240 set took a median of 48 ms against 28 unslid). The
   hull's centroid misses the hand's mostly along that axis: on frames 0 and 30 of 40
   synthetic bags (random and pinch, seeds 3540-3559; ``bench/bench_hand_region.py``) by a
   median of 11.4 mm, up to 26.6, and by 24-39 mm on a pinch (seed 3533) whose masks flood
   two of four cameras, where the unslid search needed 8 sets to find the hand.
3. **Refine**: the ``keep`` best hypotheses get ``quick_passes`` short fits (one round,
   :data:`.schedule.QUICK`) and are ranked by the caller's ``score`` (the tracking session
   passes its confidence, :mod:`.evidence`; the default is the silhouette IoU); the
   ``refine_best`` best of them get ``refine_frames`` full fits, and the best score wins. The
   ranking of the unfitted relaxed hands by IoU is weak (on a random-motion frame the
   hypothesis that ends within 15 mm ranked 11th of 48), hence the short fits of many.
4. **Fingers** (``finger_search``): every long finger in turn is tried in other states
   (:mod:`.fingers`); the palm is usually right by now, single fingers often are not.

Cost: 60 short fits and 18 full fits with the defaults, a few seconds on a 2-core machine.
"""
from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.ndimage

from hand_tracker_ros._typing import BoolArray, FloatArray
from hand_tracker_ros.config import param
from hand_tracker_ros.core.observations import FrameObservations
from hand_tracker_ros.errors import HandTrackerError, ShapeError
from hand_tracker_ros.geometry.camera_model import Camera
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.layout import Layout
from hand_tracker_ros.model.poses import RELAXED_DEG, with_joints_deg
from hand_tracker_ros.tracking.evidence import CoarseMasks, silhouette_iou
from hand_tracker_ros.tracking.fingers import search_fingers
from hand_tracker_ros.tracking.schedule import QUICK, Round
from hand_tracker_ros.tracking.tracker import Fit, HandTracker
from hand_tracker_ros.vision.visualize import paste_roi

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
    slide_best: int = param(12, 'hypotheses (best silhouette IoU first) each moved to the '
                            'offset of slide_mm along the visual hull\'s longest axis where '
                            'its IoU is highest (the live search does not)', low=0, high=500)
    slide_mm: tuple[float, ...] = param((-20.0, -10.0, 10.0, 20.0), 'offsets along the '
                                        'visual hull\'s longest axis, whose sign is '
                                        'arbitrary: give them in +- pairs (module '
                                        'docstring)', unit='mm')
    min_mask_px: int = param(50, 'masks smaller than this are ignored', unit='px', low=1)
    finger_search: bool = param(True, 'the one-shot search then tries every long finger in '
                                'other states, one at a time (tracking/fingers.py; the live '
                                'search does not)')


def _view_centre(cameras: Sequence[Camera]) -> tuple[FloatArray, float]:
    """The point closest to every optical axis (m) and the median camera distance to it (m)."""
    A, b = np.zeros((3, 3)), np.zeros(3)
    for camera in cameras:
        axis = camera.R_cam_world[2]                  # the optical axis in the world frame
        P = np.eye(3) - np.outer(axis, axis)
        A += P
        b += P @ camera.center_world
    centre = np.asarray(np.linalg.lstsq(A, b, rcond=None)[0], np.float64)
    return centre, float(np.median([np.linalg.norm(c.center_world - centre) for c in cameras]))


@dataclass(frozen=True, eq=False)
class HandRegion:
    """Where the visual hull puts the hand."""

    centre_m: FloatArray   # (3,) m, the centroid of the hull's largest connected part
    axis: FloatArray       # (3,) unit, that part's longest principal axis (sign arbitrary;
    #                        any unit vector when the part is round or one voxel)


class VisualHull:
    """Where the hand is: the centre (m) and the longest axis of the largest region every
    camera sees as foreground (:class:`HandRegion`).

    A voxel grid (``voxel_m``) around the point the cameras look at, half as wide as their
    median distance to it, is carved: a voxel stays when it projects onto foreground in every
    camera with a foreground region (the visual hull of the masks). The centroid of
    the largest connected part of what stays is the hand centre. Skin-coloured clutter in one
    camera does not survive the others, unlike the mask centroids, which it pulls away (on
    random-motion frames with the default clutter the centroids missed the hand by 20-55 mm).

    The grid's pixel in each camera is kept per set of cameras with a foreground region (at
    most ``_KEPT`` sets, 4 bytes per voxel and camera): the cameras do not move, and
    projecting the grid (about 230k voxels, with distortion, into each camera) was most of
    the 15 ms that locating the hand took on every set of a live search at 4 x 320x240; with
    them kept it is a lookup per camera.
    """

    _KEPT = 4

    def __init__(self, cameras: Sequence[Camera], voxel_m: float = 0.01) -> None:
        self.cameras = tuple(cameras)
        self.voxel_m = voxel_m
        # camera indices -> grid centre (3,) m, half width n (voxels), and per camera the
        # full-image flat pixel (N,) int32 of every voxel, W * H where it projects outside.
        self._grids: dict[tuple[int, ...], tuple[FloatArray, int, list[np.ndarray]]] = {}

    def region(self, masks: Sequence[np.ndarray], min_px: int,
               rois_px: Sequence[tuple[int, int, int, int]] | None = None) -> HandRegion:
        """The hand's region from one bool mask per camera.

        A mask covers the camera's whole image, or its ``rois_px`` box ``(u0, v0, u1, v1)``
        (half-open, full-image px; :class:`~hand_tracker_ros.vision.features.CameraFeatures`),
        outside which nothing counts as foreground. Masks with fewer than ``min_px`` foreground
        pixels are left out. Raises ``HandTrackerError`` when fewer than two cameras see
        foreground or their regions do not intersect, ``ShapeError`` for a mask per camera
        missing or of another size than its box.
        """
        if len(masks) != len(self.cameras) or (rois_px is not None
                                               and len(rois_px) != len(masks)):
            msg = f'{len(masks)} masks for {len(self.cameras)} cameras'
            raise ShapeError(msg)
        used = tuple(i for i, m in enumerate(masks) if np.count_nonzero(m) >= min_px)
        if len(used) < 2:
            msg = f'cannot place the hand: only {len(used)} camera(s) see a foreground region'
            raise HandTrackerError(msg)
        centre, n, pixels = self._grid(used)
        hull: BoolArray = np.ones(len(pixels[0]), bool)
        for i, flat in zip(used, pixels):
            camera = self.cameras[i]
            box = (0, 0, camera.width, camera.height) if rois_px is None else rois_px[i]
            hull &= _foreground(np.asarray(masks[i], bool), box, camera)[flat]
        hull = hull.reshape((2 * n + 1,) * 3)
        labels, count = scipy.ndimage.label(hull)
        if count == 0:
            msg = 'cannot place the hand: the cameras\' foreground regions do not intersect'
            raise HandTrackerError(msg)
        largest = 1 + int(np.argmax(scipy.ndimage.sum_labels(hull, labels, range(1, count + 1))))
        axis = np.arange(-n, n + 1) * self.voxel_m
        ix, iy, iz = np.unravel_index(np.flatnonzero(labels == largest), hull.shape)
        voxels_m = np.stack([axis[ix], axis[iy], axis[iz]], axis=-1) + centre   # (N, 3)
        mean = voxels_m.mean(axis=0)
        centred = voxels_m - mean
        spread = centred.T @ centred                                           # (3, 3)
        return HandRegion(mean, np.linalg.eigh(spread)[1][:, -1])

    def locate(self, observations: FrameObservations, min_px: int) -> HandRegion:
        """:meth:`region` from the observed foreground masks and their regions of interest."""
        features = [c.features for c in observations.cameras]
        return self.region([f.mask for f in features], min_px, [f.roi_px for f in features])

    def _grid(self, used: tuple[int, ...]) -> tuple[FloatArray, int, list[np.ndarray]]:
        if used not in self._grids:
            if len(self._grids) >= self._KEPT:
                del self._grids[next(iter(self._grids))]       # the oldest
            cameras = [self.cameras[i] for i in used]
            centre, distance = _view_centre(cameras)
            n = max(1, int(round(0.5 * distance / self.voxel_m)))
            axis = np.arange(-n, n + 1) * self.voxel_m
            grid = (np.stack(np.meshgrid(axis, axis, axis, indexing='ij'), axis=-1)
                    .reshape(-1, 3) + centre)
            pixels = []
            for camera in cameras:
                uv, depth = camera.project(grid)
                inside = (depth > 0) & np.all(np.isfinite(uv), axis=1)
                col = np.rint(np.nan_to_num(uv[:, 0], nan=-1.0)).astype(np.intp)
                row = np.rint(np.nan_to_num(uv[:, 1], nan=-1.0)).astype(np.intp)
                inside &= ((col >= 0) & (col < camera.width) & (row >= 0)
                           & (row < camera.height))
                pixels.append(np.where(inside, row * camera.width + col,
                                       camera.width * camera.height).astype(np.int32))
            self._grids[used] = (centre, n, pixels)
        return self._grids[used]


def _foreground(mask: np.ndarray, box: tuple[int, int, int, int], camera: Camera
                ) -> np.ndarray:
    """The camera's whole-image mask (W * H + 1,) bool, flattened, from ``mask`` (h, w)
    covering the full-image box ``(u0, v0, u1, v1)``; the entry appended is background, the
    pixel of the voxels that project outside the image."""
    u0, v0, u1, v1 = box
    if mask.shape != (v1 - v0, u1 - u0):
        msg = f'a {mask.shape[1]}x{mask.shape[0]} mask for the box {box}'
        raise ShapeError(msg)
    full = paste_roi(mask, box, (camera.width, camera.height), fill=False)
    return np.append(full.ravel(), False)


def hypotheses(model: HandModel, center_m: FloatArray, config: InitConfig) -> list[FloatArray]:
    """Relaxed hands over the roll x pitch grid, their mesh centroids at ``center_m``."""
    relaxed = with_joints_deg(RELAXED_DEG)
    out = []
    for roll in np.linspace(0.0, 2.0 * np.pi, config.roll_steps, endpoint=False):
        for pitch in np.deg2rad(config.pitches_deg):
            theta = relaxed.copy()
            theta[Layout.index('hand_ry')] = roll
            theta[Layout.index('hand_rx')] = pitch
            centre = model.pose(theta, jacobian=False).vertices_m.mean(axis=0)
            theta[Layout.translation] = center_m - centre
            out.append(np.clip(theta, model.lower, model.upper))
    return out


def ranked_hypotheses(tracker: HandTracker, observations: FrameObservations,
                      region: HandRegion, config: InitConfig) -> list[FloatArray]:
    """The hypotheses of :func:`hypotheses` at the region's centre, best coarse silhouette
    IoU first (ties in grid order); the ``slide_best`` best each moved to the offset of
    ``slide_mm`` along the region's axis (or none) where their IoU is highest, and ranked
    with that IoU (ties to the later offset)."""
    masks = CoarseMasks(observations, tracker.cameras)
    offsets_m = 1e-3 * np.asarray(config.slide_mm, np.float64)[:, None] * region.axis  # (S, 3)
    scored = []
    for k, theta in enumerate(hypotheses(tracker.model, region.centre_m, config)):
        vertices_m = tracker.model.pose(theta, jacobian=False).vertices_m
        scored.append((masks.iou(vertices_m), k, theta, vertices_m))
    scored.sort(key=lambda item: (-item[0], item[1]))
    for j, (iou, k, theta, vertices_m) in enumerate(scored[:config.slide_best]):
        slid = [(masks.iou(vertices_m + offset), i) for i, offset in enumerate(offsets_m)]
        best, i = max(slid, default=(iou, -1))
        if best > iou:
            moved = theta.copy()
            moved[Layout.translation] += offsets_m[i]
            scored[j] = (best, k, moved, vertices_m + offsets_m[i])
    scored.sort(key=lambda item: (-item[0], item[1]))
    return [theta for _, _, theta, _ in scored]


def initialize(tracker: HandTracker, observations: FrameObservations,
               config: InitConfig = InitConfig(),
               score: Callable[[Fit], float] | None = None,
               fingers_from: float = 0.0) -> FloatArray:
    """A pose of the hand seen in ``observations``; leaves ``tracker`` reset to it.

    ``score`` ranks the refined hypotheses (higher is better); by default the silhouette IoU.
    The finger search (step 4) runs only from a best fit that scores at least
    ``fingers_from`` (:mod:`.fingers`: below what the caller trusts, the palm is likely wrong
    too, and finger states can make a wrong palm look confident).
    """
    region = VisualHull(tracker.cameras).locate(observations, config.min_mask_px)
    ranked = ranked_hypotheses(tracker, observations, region, config)
    if score is None:
        def score(fit: Fit) -> float:
            return silhouette_iou(fit.views, observations)

    def refined(theta: FloatArray, passes: int, plan: tuple[Round, ...] | None) -> Fit:
        tracker.reset(theta)
        for _ in range(passes):
            fit = tracker.fit(observations, plan=plan, separate=plan is None)
            tracker.reset(fit.theta)
        return fit

    quick = [refined(theta, config.quick_passes, QUICK) for theta in ranked[:config.keep]]
    quick.sort(key=lambda fit: -score(fit))
    finals = [refined(fit.theta, config.refine_frames, None) for fit in quick[:config.refine_best]]
    best_score, best = max(((score(fit), fit.theta) for fit in finals), key=lambda item: item[0])
    if config.finger_search and best_score >= fingers_from:
        best_score, best = search_fingers(tracker, observations, (best_score, best), score)
    LOG.info('initialized at %s (score %.2f)', np.round(region.centre_m, 3), best_score)
    tracker.reset(best)
    return best
