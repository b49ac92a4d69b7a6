"""Is the estimate on the hand? Image evidence of one fit, and the confidence drawn from it.

Every signal compares the model, rendered into each camera (:class:`.views.ModelView`), with
that camera's observations, and is averaged over the cameras where it is defined:

- ``coverage`` ``|M & O| / |M|``: the share of the model silhouette ``M`` on observed
  foreground ``O``. A hand that drifted off the data drives it down; skin-coloured clutter
  (which enlarges ``O``) cannot;
- ``edge_coverage``: the share of the model's visible contour points within ``edge_px`` of an
  image edge. A palm turned the wrong way keeps most of the silhouette but not its inner
  contours (fingers crossing the palm, the thumb on the wrong side);
- ``tip_agreement``: the share of confident fingertip detections (score >= ``tip_min_score``)
  within ``tip_px`` of a projected model fingertip. It speaks only when there are at least
  ``min_tips`` such detections over all cameras; otherwise it takes ``tip_prior``.

The confidence is a logistic model ``p = 1 / (1 + exp(-(b + w . x)))`` of
``x = (coverage, edge_coverage, tip_agreement)``, fitted by ``bench/calibrate_failure.py`` to
the label "mean 3D joint error < 15 mm": random motion, 150 frames, under the robustness
suite's conditions (4 and 2 cameras, 30 and 15 fps, image noise 12, clutter 40), each tracked
from the ground truth and from the automatic start with the failure policy off; fit seeds 11
and 13 (3000 frames), held-out seed 14 (1500 frames); the tests use none of them. At
``p < 0.5`` (``failure.lost_below``) the fitted weights flag 100 % of the fit frames more than
30 mm off and 0.43 % of those within 10 mm; on the held-out frames 100 % and 0 %. The weights
were refitted after the silhouette's other-view check and the finger starts of the recovery
changed which frames fail (the tracker's errors under clutter no longer come with a widened
model on clutter): ``coverage`` now weighs 7.8 (0.29 before, when clutter made the share of
the model on the skin mask say little), the edges 20.5 and the tips 4.3. On the robustness
suite's held-out seeds 300 and 301 the refit raised the LOST recall with 2 cameras from 78 %
to 90 % with no more false alarms (README, Robustness). The IoU, the
pose plausibility (joint-limit and collision costs) and the data cost against its running
median were tried as further signals on an earlier fit (4 and 2 cameras, 30 and 15 fps):
their weights came out near 0 (the IoU also depends on how much foreground the cameras see
besides the hand: median 0.9 with 2 cameras, 0.6 with 4), so none of them is used.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from hand_tracker_ros._typing import BoolArray, FloatArray
from hand_tracker_ros.config import param
from hand_tracker_ros.core.observations import FrameObservations
from hand_tracker_ros.core.views import ModelView
from hand_tracker_ros.geometry.camera_model import Camera
from hand_tracker_ros.vision.edges import edges_within
from hand_tracker_ros.vision.features import CameraFeatures
from hand_tracker_ros.vision.visualize import paste_roi

SIGNALS = ('coverage', 'edge_coverage', 'tip_agreement')
# Cells across the image width of :class:`CoarseMasks`: 4 px cells at 320 px.
SPLAT_CELLS = 80


@dataclass(frozen=True)
class EvidenceConfig:
    """How the image evidence is measured and weighed (weights: ``bench/calibrate_failure.py``)."""

    edge_px: float = param(2.0, 'a model contour point within this of an image edge is '
                           'covered', unit='px', low=0.0, high=50.0)
    tip_px: float = param(12.0, 'a detection within this of a projected model fingertip '
                          'agrees with the estimate', unit='px', low=0.0, high=200.0)
    tip_min_score: float = param(0.5, 'detections below this score are not counted', low=0.0,
                                 high=1.0)
    min_tips: int = param(3, 'tip agreement speaks only with this many detections over all '
                          'cameras', low=1, high=100)
    tip_prior: float = param(0.8, 'tip agreement when too few detections speak', low=0.0,
                             high=1.0)
    bias: float = param(-22.97, 'logistic bias b')
    weights: tuple[float, ...] = param((7.78, 20.50, 4.32),
                                       'logistic weights, one per signal in the order '
                                       + ', '.join(SIGNALS))

    def __post_init__(self) -> None:
        if len(self.weights) != len(SIGNALS):
            msg = f'`weights` needs {len(SIGNALS)} numbers ({", ".join(SIGNALS)}), got ' \
                  f'{len(self.weights)}'
            raise ValueError(msg)


def _tip_distances_px(view: ModelView, fingertips_m: FloatArray, tips_uv_px: FloatArray
                      ) -> FloatArray:
    """Distance of every detection to its nearest projected model fingertip, (N,) px."""
    if tips_uv_px.shape[0] == 0:
        return np.zeros(0)
    uv, _ = view.camera.project(fingertips_m)
    return np.min(np.linalg.norm(tips_uv_px[:, None, :] - uv[None, :, :], axis=2), axis=1)


def measure(views: Sequence[ModelView], observations: FrameObservations,
            fingertips_m: FloatArray, config: EvidenceConfig) -> dict[str, float]:
    """The signals of :data:`SIGNALS` for one fit (module docstring).

    Parameters
    ----------
    views : tuple of ModelView
        The fitted model in every camera, in the order of ``observations.cameras``.
    fingertips_m : (5, 3) float64
        The fitted fingertips in the world frame (m).
    """
    coverage, edges, tip_d = [], [], []
    for view, obs in zip(views, observations.cameras):
        model, data = view.raster.mask, _full_mask(obs.features)
        model_px = np.count_nonzero(model)
        if model_px:
            coverage.append(np.count_nonzero(model & data) / model_px)
        if view.contours.uv_px.shape[0]:
            edges.append(float(np.mean(edges_within(obs.features.edges,
                                                    view.contours.uv_px, config.edge_px))))
        confident = obs.tips.uv_px[obs.tips.score >= config.tip_min_score]
        tip_d.append(_tip_distances_px(view, fingertips_m, confident))
    tips = np.concatenate(tip_d) if tip_d else np.zeros(0)
    return {
        'coverage': float(np.mean(coverage)) if coverage else 0.0,
        'edge_coverage': float(np.mean(edges)) if edges else 0.0,
        'tip_agreement': (float(np.mean(tips <= config.tip_px)) if tips.size >= config.min_tips
                          else config.tip_prior),
    }


def _full_mask(features: CameraFeatures) -> BoolArray:
    """The observed mask at full image size (features computed in a region of interest
    cover only that region; the rest is background)."""
    return paste_roi(features.mask, features.roi_px, features.image_size_px, fill=False)


def silhouette_iou(views: Sequence[ModelView], observations: FrameObservations) -> float:
    """Mean IoU of the model's and the observed masks over the cameras (0 if none overlap)."""
    ious = []
    for view, obs in zip(views, observations.cameras):
        data = _full_mask(obs.features)
        union = np.count_nonzero(view.raster.mask | data)
        if union:
            ious.append(np.count_nonzero(view.raster.mask & data) / union)
    return float(np.mean(ious)) if ious else 0.0


class CoarseMasks:
    """The observed masks on a coarse grid, for :meth:`iou`: a cheap stand-in for
    :func:`silhouette_iou` that needs no rendering, to rank many start hypotheses.

    Each camera's grid has about ``cells`` cells across the image width; a cell is foreground
    when any of its pixels is. A model is splatted: each mesh vertex marks the cell it
    projects to. The projection of every vertex of a closed mesh covers its silhouette, so no
    visibility is needed, as long as the cells are large enough for the vertices to leave no
    holes (at 4 px cells the hand spans tens of cells). On random-motion sets its ranking of
    the 48 start hypotheses has a Spearman correlation of 0.97-0.98 with the rendered IoU's,
    at 320x240 and 640x480 (``bench/bench_ranking.py``).
    """

    def __init__(self, observations: FrameObservations, cameras: Sequence[Camera],
                 cells: int = SPLAT_CELLS) -> None:
        self._cameras = tuple(cameras)
        self._cell = [max(1, int(c.width) // cells) for c in self._cameras]
        # Per camera, (rows, cols) bool: the cells with observed foreground.
        self._data = [_coarse(_full_mask(obs.features), cell)
                      for obs, cell in zip(observations.cameras, self._cell)]

    def iou(self, vertices_m: FloatArray) -> float:
        """Mean IoU over the cameras of the splat of ``vertices_m`` (V, 3) (m) and the
        observed mask; a camera where neither has a cell is left out (0 when all are)."""
        ious = []
        for camera, cell, data in zip(self._cameras, self._cell, self._data):
            rows, cols = data.shape
            uv, _ = camera.project(vertices_m)
            ij = np.floor(uv / cell)             # NaN (behind the camera) fails every test
            ok = (ij[:, 0] >= 0) & (ij[:, 0] < cols) & (ij[:, 1] >= 0) & (ij[:, 1] < rows)
            model = np.zeros((rows, cols), bool)
            model[ij[ok, 1].astype(np.intp), ij[ok, 0].astype(np.intp)] = True
            union = np.count_nonzero(model | data)
            if union:
                ious.append(np.count_nonzero(model & data) / union)
        return float(np.mean(ious)) if ious else 0.0


def _coarse(mask: BoolArray, cell: int) -> BoolArray:
    """(H, W) -> (ceil(H / cell), ceil(W / cell)): a cell is set when any of its pixels is."""
    rows, cols = -(-mask.shape[0] // cell), -(-mask.shape[1] // cell)
    padded = np.zeros((rows * cell, cols * cell), bool)
    padded[:mask.shape[0], :mask.shape[1]] = mask
    return np.asarray(padded.reshape(rows, cell, cols, cell).any(axis=(1, 3)))


def confidence(evidence: Mapping[str, float], config: EvidenceConfig) -> float:
    """``p = sigmoid(b + w . x)`` in [0, 1]; 0 when a signal is not finite."""
    x = np.array([evidence[name] for name in SIGNALS])
    if not np.all(np.isfinite(x)):
        return 0.0
    z = config.bias + float(np.dot(config.weights, x))
    return 1.0 / (1.0 + math.exp(-z)) if z > -700.0 else 0.0
