r"""E, the edge term (Ballan et al. 2012): model contour points against oriented image edges.

Correspondences (once per round, per camera). Every visible contour point ``u_i`` of the
model (``ModelView.contours``: outer silhouette and inner depth-discontinuity vertices, with
outward unit image normals ``n_i``) searches the image edge map along the line
``u_i + t n_i``, ``t in [-search_px, +search_px]``: it walks the pixels the line crosses
(4-connected traversal of Amanatides & Woo, so a thin 8-connected Canny curve is never
stepped over diagonally) forward and backward from ``u_i`` and stops at the first edge pixel
whose gradient direction ``g`` is compatible, ``|n_i . g| >= min_orientation_cos`` (polarity is
ignored: the hand may be brighter or darker than the background). Of the two hits, the one
with the smaller ``|n_i^T (c - u_i)|`` (``c`` the edge pixel centre) becomes the target
``t_i = c``. Unmatched points give no residual.

With ``inner_contours`` false only the outer silhouette's points search (the calibration's
terms, :mod:`hand_tracker_ros.calibration.frame_terms`, which says why).

Weights (square-root weights ``s_i``, Ballan's code adapted):

- image edge type from the observed foreground mask: an edge pixel is *outer* when the mask
  differs ``edge_type_probe_px`` before and after it along ``n_i`` (hand on one side only).
  An outer model point matched to an inner image edge, or the reverse, gets
  ``mismatch_weight`` (0.3) on its weight, i.e. ``sqrt(0.3)`` on ``s_i``;
- palm vertices (``vertex_part == 0``) get ``palm_sqrt_weight`` (5) on ``s_i``, as Ballan's
  x5 for the bones near the root: the palm carries the global pose.

Ballan's per-vertex area factor is left out: the sphere-mesh hand has nearly uniform
triangles. Per-bone outlier rejection per camera: with ``d_i = |n_i^T (t_i - u_i)|``, the
mean ``dbar_b`` over the matches of bone ``b``, floored at ``outlier_floor_px * W / 640``
(W the image width), rejects ``d_i > outlier_factor * dbar_b`` when bone ``b`` has at least
``outlier_min_matches`` matches.

Residual (px), one row per match, with ``n_i`` fixed for the round:

.. math:: r_i(\theta) = s_i \, n_i^T (\pi_c(X_i(\theta)) - t_i)

the signed distance of the projected point to the image edge line through ``t_i``
orthogonal to ``n_i`` (point-to-line). Why not the 2D point residual ``u_i - t_i``: the
search only measures the offset along the normal; the tangential position of ``t_i`` is
pixel rounding, and penalising it would drag contour points along the edge (the aperture
problem) and double the rows. Point-to-line also lets the contour slide along a straight
edge as the pose changes, which is what the next round's re-matching assumes.

References: docs/references.md.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from hand_tracker_ros._typing import BoolArray, Float32Array, FloatArray, Int32Array, IntArray
from hand_tracker_ros.config import param
from hand_tracker_ros.core.context import RoundContext
from hand_tracker_ros.core.observations import CameraObservation
from hand_tracker_ros.core.views import ModelView
from hand_tracker_ros.energies._projection import (
    ImageTargets,
    block_vertices,
    image_linearize,
    image_residuals,
)
from hand_tracker_ros.errors import ShapeError
from hand_tracker_ros.model.hand import HandModel, PosedHand
from hand_tracker_ros.vision.edges import EdgeMap

_REFERENCE_WIDTH_PX = 640.0


@dataclass(frozen=True)
class EdgeEnergyConfig:
    """The edge term E."""

    enabled: bool = param(True, 'use the edge term')
    weight: float = param(1.0, 'term weight (cost = 0.5 * weight * |r|^2, r in px)',
                          low=0.0, high=1e6)
    search_px: float = param(15.0, 'half-length of the 1D search along the model normal '
                             '(15 suits 320x240; scale it with the resolution)', unit='px',
                             low=1.0, high=200.0)
    min_orientation_cos: float = param(0.7, 'minimum |cos| between model normal and image '
                                       'gradient for a compatible edge', low=0.0, high=1.0)
    mismatch_weight: float = param(0.3, 'weight factor when an outer model edge matches an '
                                   'inner image edge or vice versa', low=0.0, high=1.0)
    edge_type_probe_px: float = param(3.0, 'distance on both sides of an image edge pixel at '
                                      'which the foreground mask is probed', unit='px',
                                      low=0.5, high=20.0)
    palm_sqrt_weight: float = param(5.0, 'factor on the square-root weight of palm vertices',
                                    low=0.0, high=100.0)
    inner_contours: bool = param(True, 'match the inner (depth-discontinuity) contour points '
                                 'too, not only the outer silhouette\'s')
    outlier_factor: float = param(2.0, 'reject matches farther than this times the bone mean',
                                  low=1.0, high=100.0)
    outlier_floor_px: float = param(3.0, 'floor of the per-bone mean match distance at 640 px '
                                    'image width (scaled with the width)', unit='px',
                                    low=0.0, high=100.0)
    outlier_min_matches: int = param(20, 'bones with fewer matches skip the outlier test',
                                     low=1, high=100000)


@dataclass(frozen=True, eq=False)
class EdgeCorrespondences:
    """Edge matches of one round: one line-row block per camera (rig order)."""

    blocks: tuple[ImageTargets, ...]

    @property
    def n_residuals(self) -> int:
        """Residual count M."""
        return sum(b.n_rows for b in self.blocks)


@numba.njit(cache=True, nogil=True)
def _walk(edges: BoolArray, orient: Float32Array, u0: int, v0: int, pu: float, pv: float,
          du: float, dv: float, max_t: float, min_cos: float) -> tuple[int, int, bool]:
    """First compatible edge pixel crossed by ``p + t d``, ``0 <= t <= max_t``."""
    height, width = edges.shape
    cu, cv = int(math.floor(pu + 0.5)), int(math.floor(pv + 0.5))
    su, sv = (1 if du > 0 else -1), (1 if dv > 0 else -1)
    tu = (cu + 0.5 * su - pu) / du if du != 0.0 else np.inf
    tv = (cv + 0.5 * sv - pv) / dv if dv != 0.0 else np.inf
    dtu = abs(1.0 / du) if du != 0.0 else np.inf
    dtv = abs(1.0 / dv) if dv != 0.0 else np.inf
    t = 0.0
    while t <= max_t:
        col, row = cu - u0, cv - v0
        if 0 <= col < width and 0 <= row < height and edges[row, col]:
            o = orient[row, col]
            if abs(du * math.cos(o) + dv * math.sin(o)) >= min_cos:
                return cu, cv, True
        if tu < tv:
            t, cu, tu = tu, cu + su, tu + dtu
        else:
            t, cv, tv = tv, cv + sv, tv + dtv
    return 0, 0, False


@numba.njit(cache=True, nogil=True)
def _search(edges: BoolArray, orient: Float32Array, u0: int, v0: int, uv: FloatArray,
            normals: FloatArray, max_t: float, min_cos: float) -> tuple[FloatArray, BoolArray]:
    """Nearer of the forward/backward hits of every point.

    numba because the walk is a per-pixel loop with an early exit at the first hit, which
    vectorised numpy could only emulate by sampling all ``2 * search_px`` pixels of every
    point; ``cache=True`` stores the machine code so the compile is paid once, not per
    process.
    """
    n = uv.shape[0]
    target = np.zeros((n, 2))
    found = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        best = np.inf
        for sign in (1.0, -1.0):
            du, dv = sign * normals[i, 0], sign * normals[i, 1]
            cu, cv, hit = _walk(edges, orient, u0, v0, uv[i, 0], uv[i, 1], du, dv, max_t,
                                min_cos)
            if hit:
                d = abs(normals[i, 0] * (cu - uv[i, 0]) + normals[i, 1] * (cv - uv[i, 1]))
                if d < best:
                    best = d
                    target[i, 0], target[i, 1] = cu, cv
                    found[i] = True
    return target, found


def search_edges(edge_map: EdgeMap, uv_px: FloatArray, normals_px: FloatArray,
                 search_px: float, min_cos: float) -> tuple[FloatArray, BoolArray]:
    """1D search of the nearest compatible image edge along +-normal (see module docstring).

    Parameters
    ----------
    edge_map : EdgeMap
        Image edges (full image or ROI).
    uv_px : (N, 2) float64
        Query points (full-image px).
    normals_px : (N, 2) float64
        Unit search directions.
    search_px : float
        Maximum search distance (px) each way.
    min_cos : float
        Orientation gate on ``|normal . gradient direction|``.

    Returns
    -------
    targets_px : (N, 2) float64
        Centre of the matched edge pixel (0 where not found).
    found : (N,) bool
    """
    u0, v0 = edge_map.offset_uv_px
    return _search(edge_map.edges, edge_map.orientation_rad, u0, v0,
                   np.ascontiguousarray(uv_px, dtype=np.float64),
                   np.ascontiguousarray(normals_px, dtype=np.float64),
                   float(search_px), float(min_cos))


def reject_outliers(distance_px: FloatArray, part: IntArray, floor_px: float, factor: float,
                    min_matches: int) -> BoolArray:
    """Per-bone outlier test (Ballan's ``Clean_TargetList_2D_FromOutliers``).

    Parameters
    ----------
    distance_px : (N,) float64
        Match distances.
    part : (N,) int
        Bone of each match.
    floor_px, factor : float
        ``keep = d <= factor * max(mean_b(d), floor_px)`` ...
    min_matches : int
        ... applied only to bones with at least this many matches.

    Returns
    -------
    keep : (N,) bool
    """
    if part.size == 0:
        return np.ones(0, dtype=bool)
    count = np.bincount(part)
    mean = np.bincount(part, weights=distance_px) / np.maximum(count, 1)
    limit = factor * np.maximum(mean, floor_px)
    return (count[part] < min_matches) | (distance_px <= limit[part])


class EdgeEnergy:
    """The edge term; see the module docstring.

    Parameters
    ----------
    config : EdgeEnergyConfig
    vertex_part : (V,) int
        Bone of each mesh vertex (``HandModel.vertex_part``; 0 is the palm).
    """

    name = 'edges'

    def __init__(self, config: EdgeEnergyConfig, vertex_part: IntArray | Int32Array) -> None:
        self.config = config
        self.vertex_part = np.asarray(vertex_part, dtype=np.int64)

    @classmethod
    def from_model(cls, config: EdgeEnergyConfig, model: HandModel) -> EdgeEnergy:
        """The term for ``model`` (a HandModel)."""
        return cls(config, model.vertex_part)

    @property
    def weight(self) -> float:
        """Weight of the term's cost ``0.5 * weight * |r|^2``."""
        return self.config.weight

    def correspond(self, context: RoundContext) -> EdgeCorrespondences:
        """Match every camera's contour points to image edges (no blocks when disabled)."""
        cameras = context.observations.cameras
        if len(cameras) != len(context.views):
            msg = f'{len(context.views)} model views for {len(cameras)} cameras'
            raise ShapeError(msg)
        if not self.config.enabled:
            return EdgeCorrespondences(())
        return EdgeCorrespondences(tuple(self._match(view, obs)
                                         for view, obs in zip(context.views, cameras)))

    def residuals(self, posed: PosedHand, correspondences: EdgeCorrespondences) -> FloatArray:
        """Point-to-line residuals ``r (M,)`` (px)."""
        return image_residuals(posed, correspondences.blocks)

    def linearize(self, posed: PosedHand, correspondences: EdgeCorrespondences
                  ) -> tuple[FloatArray, FloatArray]:
        """Residuals ``r (M,)`` (px) and analytic Jacobian ``J (M, P)``."""
        return image_linearize(posed, correspondences.blocks)

    def jacobian_vertices(self, correspondences: EdgeCorrespondences) -> IntArray:
        """Vertex ids (K,) int64 the rows read."""
        return block_vertices(correspondences.blocks)

    def _match(self, view: ModelView, obs: CameraObservation) -> ImageTargets:
        cfg = self.config
        contours = view.contours
        use = slice(None) if cfg.inner_contours else np.flatnonzero(contours.is_outer)
        uv, normals = contours.uv_px[use], contours.normals_px[use]
        ids, is_outer = contours.vertex_ids[use], contours.is_outer[use]
        target, found = search_edges(obs.features.edges, uv, normals, cfg.search_px,
                                     cfg.min_orientation_cos)
        distance = np.abs(np.einsum('ni,ni->n', normals, target - uv))
        part = self.vertex_part[ids]
        floor = cfg.outlier_floor_px * view.camera.width / _REFERENCE_WIDTH_PX
        keep = found.copy()
        keep[found] = reject_outliers(distance[found], part[found], floor,
                                      cfg.outlier_factor, cfg.outlier_min_matches)
        target, normals = target[keep], normals[keep]
        sqrt_w = np.where(part[keep] == 0, cfg.palm_sqrt_weight, 1.0)
        probe = cfg.edge_type_probe_px * normals
        mask_at = obs.features.mask_at
        image_outer = mask_at(target + probe) != mask_at(target - probe)
        mismatch = image_outer != is_outer[keep]
        sqrt_w = sqrt_w * np.where(mismatch, math.sqrt(cfg.mismatch_weight), 1.0)
        return ImageTargets(view.camera, ids[keep], target, sqrt_w, normals)
