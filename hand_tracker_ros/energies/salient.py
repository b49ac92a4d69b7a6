r"""S, the salient-point term (Ballan et al. ECCV 2012): fingertip detections with joint labels.

The fingertip detector gives unlabelled 2D points. Which finger each belongs to is estimated
together with the pose: at every correspondence round, in every camera, the detections are
assigned anew to the fingertip vertices of the model as it is posed at the start of the round.

Assignment. Let ``y_j`` (j < N) be the detections with score ``>= min_score`` and ``u_k`` the
projections of the model fingertips that show in the current raster
(:func:`hand_tracker_ros.render.fingertips.visible_fingertips`: the vertex test with the depth
slack of the tip cap, as in the detector's training labels). With the distances
``d_jk = |y_j - u_k|`` and the gate ``g``, we minimise over partial matchings ``A``

.. math:: \sum_{(j,k) \in A} d_{jk} + g \, \#\{j \text{ unassigned}\},
          \qquad d_{jk} \le g \text{ for every } (j, k) \in A,

each detection and each fingertip used at most once. This is Ballan's linear program with
"missing data" slack variables of cost lambda = gate (``SolveAssociationProblem_with_missing
_data_correct``); his LP has integral optima, so the Hungarian method solves it exactly:
:func:`scipy.optimize.linear_sum_assignment` on the N x (K + N) matrix ``[D | g 1]``, whose N
dummy columns of cost ``g`` let any detection stay unassigned, and where the entries of ``D``
above the gate are infinite (forbidden). A fingertip without a detection costs nothing
(fingertips are often occluded or missed by the detector).

The gate is given in px at a reference image width and scales with the width:
``g = gate_px * width / reference_width_px``. Ballan's 30 px at ~1000-1400 px images is about
7-10 px at 320 px; the default, 12 px at 320 px, leaves room for the larger pose errors of the
first rounds at low resolution.

Residual of an assigned pair (fingertip vertex ``X_k``, detection ``y_j`` with score
``s_j``), 2 rows in px:

.. math:: r_j(\theta) = \sqrt{s_j} \, (\pi_c(X_k(\theta)) - y_j),

with the Jacobian ``sqrt(s_j) d pi_c / dX . dX_k / d theta`` (see :mod:`._projection`). The
confidence weight ``sqrt(s_j)`` makes the cost of a pair proportional to the score.

References: docs/references.md.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.spatial.distance import cdist

from hand_tracker_ros._typing import FloatArray, IntArray
from hand_tracker_ros.checks import check_finite, check_shape
from hand_tracker_ros.config import param
from hand_tracker_ros.core.context import RoundContext
from hand_tracker_ros.core.observations import CameraObservation
from hand_tracker_ros.energies._projection import (
    ImageTargets,
    block_vertices,
    image_linearize,
    image_residuals,
)
from hand_tracker_ros.model.hand import HandModel, PosedHand
from hand_tracker_ros.render.fingertips import cap_slack_m, visible_fingertips
from hand_tracker_ros.render.rasterizer import RenderResult

NAME = 'salient'


@dataclass(frozen=True)
class SalientConfig:
    """The salient-point term S."""

    enabled: bool = param(True, 'use the salient-point (fingertip) term')
    weight: float = param(0.3, 'term weight (cost = 0.5 * weight * |r|^2, r in px); below the '
                          'edge weight because some detections are false (bench_detector: '
                          'precision 0.94 at min_score 0.5)',
                          low=0.0, high=1e6)
    min_score: float = param(0.5, 'detections below this score are ignored', low=0.0,
                             high=1.0)
    gate_px: float = param(12.0, 'largest detection-to-fingertip distance of an assigned '
                           'pair, and the cost of leaving a detection unassigned, at '
                           '`reference_width_px` (scales with the image width)', unit='px',
                           low=0.1, high=1000.0)
    reference_width_px: int = param(320, 'image width at which `gate_px` holds', unit='px',
                                    low=1, high=100000)


@dataclass(frozen=True, eq=False)
class SalientCorrespondences:
    """The fingertip assignment of one round.

    Attributes
    ----------
    blocks : tuple of ImageTargets
        One per camera with assigned pairs (point rows, weights ``sqrt(score)``).
    labels : tuple of (N_c,) int64
        Per camera of the observations (rig order), the finger of each detection in the
        order of ``CameraObservation.tips``: 0 thumb .. 4 pinky, or -1 (unassigned or below
        ``min_score``).
    """

    blocks: tuple[ImageTargets, ...]
    labels: tuple[IntArray, ...]

    @property
    def n_residuals(self) -> int:
        """M = 2 x the number of assigned pairs."""
        return sum(b.n_rows for b in self.blocks)


def assign_detections(tips_uv_px: FloatArray, detections_uv_px: FloatArray,
                      gate_px: float) -> IntArray:
    """Optimal gated assignment of detections to fingertips (see the module docstring).

    Parameters
    ----------
    tips_uv_px : (K, 2) float64
        Projected model fingertips.
    detections_uv_px : (N, 2) float64
        Detections.
    gate_px : float
        Largest distance of an assigned pair; cost of an unassigned detection.

    Returns
    -------
    tip_of_detection : (N,) int64
        Row of ``tips_uv_px`` assigned to each detection, or -1.
    """
    check_shape('tips_uv_px', tips_uv_px, (None, 2))
    check_shape('detections_uv_px', detections_uv_px, (None, 2))
    check_finite('tips_uv_px', tips_uv_px)
    n, k = detections_uv_px.shape[0], tips_uv_px.shape[0]
    out = np.full(n, -1, dtype=np.int64)
    if n == 0 or k == 0:
        return out
    dist = cdist(detections_uv_px, tips_uv_px)
    cost = np.full((n, k + n), float(gate_px))
    cost[:, :k] = np.where(dist <= gate_px, dist, np.inf)
    rows, cols = linear_sum_assignment(cost)
    real = cols < k
    out[rows[real]] = cols[real]
    return out


class SalientEnergy:
    """The salient-point term S (see the module docstring).

    Parameters
    ----------
    config : SalientConfig
    fingertip_vertex_ids : (5,) int
        Mesh vertex of each fingertip, thumb to pinky (``HandModel.fingertip_vertex_ids``).
    tip_slack_m : (5,) float
        Depth slack of each fingertip's visibility test
        (:func:`hand_tracker_ros.render.fingertips.cap_slack_m`), m.
    """

    name = NAME

    def __init__(self, config: SalientConfig, fingertip_vertex_ids: IntArray,
                 tip_slack_m: FloatArray) -> None:
        self.config = config
        self.fingertip_vertex_ids = np.asarray(fingertip_vertex_ids, dtype=np.int64)
        self.tip_slack_m = np.asarray(tip_slack_m, dtype=np.float64)
        check_shape('fingertip_vertex_ids', self.fingertip_vertex_ids, (None,))
        check_shape('tip_slack_m', self.tip_slack_m, self.fingertip_vertex_ids.shape)

    @classmethod
    def from_model(cls, config: SalientConfig, model: HandModel) -> SalientEnergy:
        """The term for a :class:`~hand_tracker_ros.model.hand.HandModel`."""
        return cls(config, model.fingertip_vertex_ids, cap_slack_m(model))

    def gate_px(self, width_px: int) -> float:
        """The gate (px) in an image ``width_px`` wide."""
        return self.config.gate_px * width_px / self.config.reference_width_px

    @property
    def weight(self) -> float:
        """Weight of the term's cost ``0.5 * weight * |r|^2``."""
        return self.config.weight

    def correspond(self, context: RoundContext) -> SalientCorrespondences:
        """Assign every camera's detections to the visible model fingertips.

        Parameters
        ----------
        context : RoundContext
            Uses ``views[c].raster`` (projections and visibility of the model at the start of
            the round) and ``observations.cameras[c].tips``.
        """
        blocks, labels = [], []
        for obs, view in zip(context.observations.cameras, context.views):
            finger = self._camera_labels(obs, view.raster)
            labels.append(finger)
            det = np.flatnonzero(finger >= 0)
            if det.size:
                blocks.append(ImageTargets(obs.camera, self.fingertip_vertex_ids[finger[det]],
                                           obs.tips.uv_px[det], np.sqrt(obs.tips.score[det])))
        return SalientCorrespondences(tuple(blocks), tuple(labels))

    def _camera_labels(self, obs: CameraObservation, raster: RenderResult) -> IntArray:
        """(N,) finger of each detection of one camera, or -1."""
        tips = obs.tips
        labels = np.full(tips.score.shape[0], -1, dtype=np.int64)
        uv = raster.uv_px[self.fingertip_vertex_ids]
        fingers = np.flatnonzero(visible_fingertips(raster, self.fingertip_vertex_ids,
                                                    self.tip_slack_m)
                                 & np.all(np.isfinite(uv), axis=1))
        strong = np.flatnonzero(tips.score >= self.config.min_score)
        tip = assign_detections(uv[fingers], tips.uv_px[strong], self.gate_px(obs.camera.width))
        assigned = tip >= 0
        labels[strong[assigned]] = fingers[tip[assigned]]
        return labels

    def residuals(self, posed: PosedHand, correspondences: SalientCorrespondences) -> FloatArray:
        """Residuals ``r (M,)`` (px): ``sqrt(score) (u_tip - y)`` per pair, u then v."""
        return image_residuals(posed, correspondences.blocks)

    def linearize(self, posed: PosedHand, correspondences: SalientCorrespondences
                  ) -> tuple[FloatArray, FloatArray]:
        """Residuals ``r (M,)`` (px) and analytic Jacobian ``J (M, P)`` (px per unit)."""
        return image_linearize(posed, correspondences.blocks)

    def jacobian_vertices(self, correspondences: SalientCorrespondences) -> IntArray:
        """Vertex ids (K,) int64 the rows read."""
        return block_vertices(correspondences.blocks)
