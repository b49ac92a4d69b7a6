r"""O, the optical-flow term (Ballan et al. ECCV 2012): model points carried by the image flow.

Once per correspondence round, in every camera ``c`` with a flow field from frame t-1 to t:

1. take the mesh vertices visible at t-1 (the previous estimate's raster) and their
   projections ``p_i`` at t-1;
2. carry them by the flow: ``t_i = flow_c(p_i)`` (dense DIS flow sampled bilinearly, or the
   sparse Lucas-Kanade track attached to ``p_i`` within a radius, as in Ballan's code);
   points without a valid flow are dropped;
3. keep at most ``max_points`` of them, spread evenly over the vertex ids by a fixed stride
   (deterministic; vertex ids run along the parts, so a stride samples every visible part);
4. reject outliers per bone like Ballan's ``Clean_TargetList_2D_FromOutliers``: with
   ``d_i = |u_i(theta_round) - t_i|`` the displacement still to go from the model at the start
   of the round, and ``m_b = max(mean_{i in b} d_i, floor)`` for the ``n_b`` points of bone
   ``b``, a point is dropped when ``n_b >= min_bone_points`` and ``d_i > factor * m_b``; a
   bone with a single point is dropped (one track cannot be told from an outlier). The floor
   is given at a reference width and scales with the image width, like the salient gate.

The residual of a kept point is the reprojection error of its vertex against the fixed target,

.. math:: r_i(\theta) = \pi_c(X_i(\theta)) - t_i \qquad (2 \text{ rows, px}),

with the Jacobian ``d pi_c / dX . dX_i / d theta`` (see :mod:`._projection`). Rows are not
weighted (all ``sqrt_weights`` are 1): Ballan's per-vertex area weights compensate for his
uneven mesh, while the sphere-mesh hand's triangles are of similar size.

No previous frame, or no flow in a camera (first frame, reset, flow disabled), gives no rows
from that camera; M = 0 overall then. Switching the term off after the first rounds of a
frame (Ballan: 25 %) is the tracker's schedule, not this module's.

References: docs/references.md.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hand_tracker_ros._typing import BoolArray, FloatArray, Int32Array, IntArray
from hand_tracker_ros.config import param
from hand_tracker_ros.core.context import RoundContext
from hand_tracker_ros.energies._projection import (
    ImageTargets,
    block_vertices,
    image_linearize,
    image_residuals,
)
from hand_tracker_ros.geometry.camera_model import Camera
from hand_tracker_ros.model.hand import HandModel, PosedHand
from hand_tracker_ros.render.rasterizer import RenderResult
from hand_tracker_ros.vision.flow import FlowField

NAME = 'flow'


@dataclass(frozen=True)
class FlowEnergyConfig:
    """The optical-flow term O."""

    enabled: bool = param(True, 'use the optical-flow term')
    weight: float = param(1.0, 'term weight (cost = 0.5 * weight * |r|^2, r in px)',
                          low=0.0, high=1e6)
    max_points: int = param(150, 'largest number of flow targets per camera', low=1,
                            high=100000)
    outlier_factor: float = param(2.0, 'drop targets farther than this times their bone\'s '
                                  'mean displacement (Ballan: 2)', low=1.0, high=100.0)
    outlier_floor_px: float = param(2.0, 'floor of a bone\'s mean displacement in the '
                                    'outlier test, at `reference_width_px` (scales with the '
                                    'image width; Ballan: 3 px at ~1400 px)', unit='px',
                                    low=0.0, high=100.0)
    min_bone_points: int = param(20, 'outlier test only on bones with at least this many '
                                 'targets (Ballan: 20)', low=2, high=100000)
    reference_width_px: int = param(320, 'image width at which `outlier_floor_px` holds',
                                    unit='px', low=1, high=100000)


@dataclass(frozen=True, eq=False)
class FlowCorrespondences:
    """The flow targets of one round.

    Attributes
    ----------
    blocks : tuple of ImageTargets
        One per camera that contributed targets (point rows, unit weights).
    """

    blocks: tuple[ImageTargets, ...]

    @property
    def n_residuals(self) -> int:
        """M = 2 x the number of targets."""
        return sum(b.n_rows for b in self.blocks)


def reject_bone_outliers(bone: IntArray, dist_px: FloatArray, *, factor: float,
                         floor_px: float, min_points: int) -> BoolArray:
    """Ballan's per-bone outlier test (see the module docstring, step 4).

    Parameters
    ----------
    bone : (N,) int
        Bone (part) of each target.
    dist_px : (N,) float64
        Displacement of each target from the current model projection.
    factor, floor_px, min_points
        Keep ``dist <= factor * max(bone mean, floor_px)`` on bones with ``>= min_points``
        targets; bones with exactly one target are dropped.

    Returns
    -------
    keep : (N,) bool
    """
    bone = np.asarray(bone, dtype=np.int64)
    if bone.size == 0:
        return np.zeros(0, dtype=bool)
    _, index, count = np.unique(bone, return_inverse=True, return_counts=True)
    mean = np.bincount(index, weights=dist_px) / count
    limit = factor * np.maximum(mean, floor_px)
    tested = count[index] >= min_points
    return (count[index] > 1) & ~(tested & (dist_px > limit[index]))


def stride_subsample(ids: IntArray, max_points: int) -> IntArray:
    """At most ``max_points`` of ``ids`` at a fixed stride ``ceil(N / max_points)``."""
    stride = max(1, math.ceil(ids.size / max_points))
    return ids[::stride]


class FlowEnergy:
    """The optical-flow term O (see the module docstring).

    Parameters
    ----------
    config : FlowEnergyConfig
    vertex_part : (V,) int
        Bone of each mesh vertex (``HandModel.vertex_part``), for the per-bone outlier test.
    """

    name = NAME

    def __init__(self, config: FlowEnergyConfig, vertex_part: IntArray | Int32Array) -> None:
        self.config = config
        self.vertex_part = np.asarray(vertex_part, dtype=np.int64)

    @classmethod
    def from_model(cls, config: FlowEnergyConfig, model: HandModel) -> FlowEnergy:
        """The term for a :class:`~hand_tracker_ros.model.hand.HandModel`."""
        return cls(config, model.vertex_part)

    @property
    def weight(self) -> float:
        """Weight of the term's cost ``0.5 * weight * |r|^2``."""
        return self.config.weight

    def correspond(self, context: RoundContext) -> FlowCorrespondences:
        """Flow targets of the points visible at t-1, per camera (empty without flow).

        Parameters
        ----------
        context : RoundContext
            Uses ``previous.views`` (t-1 raster), ``views`` (the model at the start of the
            round, for the outlier test) and each camera's ``features.flow``.
        """
        previous = context.previous
        if previous is None:
            return FlowCorrespondences(())
        blocks = []
        for c, obs in enumerate(context.observations.cameras):
            flow = None if obs.features is None else obs.features.flow
            if flow is None:
                continue
            block = self._camera_targets(obs.camera, flow, previous.views[c].raster,
                                         context.views[c].raster.uv_px)
            if block.vertex_ids.size:
                blocks.append(block)
        return FlowCorrespondences(tuple(blocks))

    def _camera_targets(self, camera: Camera, flow: FlowField,
                        prev_raster: RenderResult,
                        uv_now_px: FloatArray) -> ImageTargets:
        """Targets of one camera: visible at t-1, valid flow, subsampled, outliers removed."""
        cfg = self.config
        ids = np.flatnonzero(prev_raster.visible_vertices)
        # A point behind the camera now has no displacement to test: leave it out.
        ids = ids[np.all(np.isfinite(uv_now_px[ids]), axis=1)]
        targets, valid = flow.flow_at(prev_raster.uv_px[ids])
        keep = stride_subsample(np.flatnonzero(valid), cfg.max_points)
        ids, targets = ids[keep], targets[keep]
        dist = np.linalg.norm(uv_now_px[ids] - targets, axis=1)
        floor_px = cfg.outlier_floor_px * camera.width / cfg.reference_width_px
        inlier = reject_bone_outliers(self.vertex_part[ids], dist, factor=cfg.outlier_factor,
                                      floor_px=floor_px, min_points=cfg.min_bone_points)
        ids, targets = ids[inlier], targets[inlier]
        return ImageTargets(camera, ids, targets, np.ones(ids.size))

    def residuals(self, posed: PosedHand, correspondences: FlowCorrespondences) -> FloatArray:
        """Residuals ``r (M,)`` (px): ``u_i - t_i`` per target, u then v."""
        return image_residuals(posed, correspondences.blocks)

    def linearize(self, posed: PosedHand, correspondences: FlowCorrespondences
                  ) -> tuple[FloatArray, FloatArray]:
        """Residuals ``r (M,)`` (px) and analytic Jacobian ``J (M, P)`` (px per unit)."""
        return image_linearize(posed, correspondences.blocks)

    def jacobian_vertices(self, correspondences: FlowCorrespondences) -> IntArray:
        """Vertex ids (K,) int64 the rows read."""
        return block_vertices(correspondences.blocks)
