r"""Sil, the silhouette term in 3D (second seed, "Silhouette energy").

Model points that project outside the observed hand silhouette are pulled, in 3D, onto the
camera rays through their closest data-silhouette pixels:

.. math:: E_S = \sum_{m \in M} \| n^T (m - p) \|^2

Correspondences (once per round, per camera). The model silhouette points ``m`` are the
OUTER contour vertices of the view (``ModelView.contours`` with ``is_outer``), thinned to at
most ``max_points_per_camera`` by an even stride. Those whose projection ``u`` lies outside
the observed foreground mask (``CameraFeatures.mask_at``) are matched, in 2D, to the closest
foreground pixel ``q`` (for a point outside the mask the closest foreground pixel is a
silhouette pixel) by ``cv2.distanceTransformWithLabels`` of the mask's complement, computed
only on the window of the queries' bounding box grown by the search cap (a nearer pixel
within the cap always lies in it). Matches farther than ``max_distance_px`` are dropped, and
so are points within ``tolerance_px`` of the pixel centre: a silhouette vertex rounds to a
background pixel half the time although it lies on the boundary, and matching it would
shrink the model by the mask quantisation. The silhouette boundary itself passes half a
pixel from the pixel centre towards ``u``, so the target is
``t = q + 0.5 (u - q) / |u - q|``, which defines the ray ``p + s d`` (``p`` the camera
centre, ``d`` the unit direction of ``t`` from :meth:`PinholeCamera.rays`). With
``w = (m - p) - ((m - p)^T d) d`` at correspondence time, ``n = w / |w|`` is the unit
vector orthogonal to the ray pointing from the ray to ``m``, held fixed for the round.

Residual, one row per match, in metres (the signed distance of ``m`` to the plane through
the ray orthogonal to ``n``; it equals the 3D point-to-ray distance when the round starts):

.. math::

    r = n^T (X_i(\theta) - p), \qquad
    \frac{\partial r}{\partial \theta} = n^T \frac{\partial X_i}{\partial \theta}

Why 3D and not 2D: the seed reports that the projective (2D) formulation overshoots in the
parameter updates because of the division by depth in the projection; the 3D residual is
linear in the vertex. Points already inside the observed mask contribute nothing.

Data to model (``data_to_model_weight`` > 0, the symmetric push of htrack's two-sided
silhouette term):
observed silhouette pixels ``q`` (foreground pixels with a background 4-neighbour, evenly
thinned to ``max_points_per_camera``) that the rendered model does not cover are matched to
their nearest outer contour point ``u`` (2D brute-force search, within ``max_distance_px``, farther
than ``tolerance_px``); that vertex gets the same residual against the ray through
``q + 0.5 (q - u) / |q - u|``, the boundary half a pixel beyond ``q``. Without it the term
only pulls the model into the mask and never grows it over uncovered data (e.g. a model
too far from a single camera looks too small and gets no row at all; the test shows it).
Uncovered data farther than ``max_distance_px`` from the model (a finger folded away by
more than that) is not recovered. These rows are scaled by :math:`\sqrt{\lambda}`,
``lambda = data_to_model_weight`` relative to the model-to-data rows; a vertex may receive
several rows. The default 0.15 comes from ``hand-tracker evaluate`` (full method, seed 0,
mean 3D joint error over grasp, tapping and random): 5.5 mm without these rows (a finger
that folds behind the palm stays there when it extends again: its model points are inside
the mask and nothing pulls them out), 2.5 mm at 0.05, 2.1 at 0.1, 1.8 at 0.15-0.2, 2.4 at
0.3 and 3.3 at 0.5 (stronger rows follow mask errors and skin-coloured clutter).
"""
from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Any

import cv2
import numba
import numpy as np

from hand_tracker_ros._typing import BoolArray, FloatArray, IntArray
from hand_tracker_ros.config import param
from hand_tracker_ros.errors import ShapeError
from hand_tracker_ros.tracking.observations import CameraObservation
from hand_tracker_ros.tracking.views import ModelView
from hand_tracker_ros.vision.features import CameraFeatures

_MIN_RAY_DISTANCE_M = 1e-9
_HALF_PIXEL = 0.5


@dataclass(frozen=True)
class SilhouetteConfig:
    """The 3D silhouette term Sil."""

    enabled: bool = param(True, 'use the silhouette term')
    weight: float = param(3e6, 'term weight (cost = 0.5 * weight * |r|^2, r in m); 3e6 '
                          'makes 1 mm cost like 1.7 px of an image term (tuned by hand-tracker '
                          'evaluate)', low=0.0, high=1e12)
    max_distance_px: float = param(20.0, 'largest 2D distance from a model point to its '
                                   'closest data-silhouette pixel', unit='px', low=1.0,
                                   high=500.0)
    tolerance_px: float = param(1.0, 'points this close to a foreground pixel centre count as '
                                'on the silhouette (mask quantisation)', unit='px', low=0.5,
                                high=10.0)
    max_points_per_camera: int = param(400, 'model points (and data pixels) used per camera '
                                       'and direction (even stride beyond this)', low=1,
                                       high=100000)
    data_to_model_weight: float = param(
        0.15, 'weight of the data-to-model rows (observed silhouette pixels the model does not '
        'cover pull the nearest model contour point) relative to the model-to-data rows; 0 '
        'turns them off', low=0.0, high=100.0)


@dataclass(frozen=True, eq=False)
class SilhouetteCorrespondences:
    """Point-to-ray matches of one round, all cameras stacked.

    Attributes
    ----------
    vertex_ids : (M,) int64
        Model vertex of each match.
    ray_origins_m : (M, 3) float64
        A point ``p`` of each ray (the camera centre).
    normals : (M, 3) float64
        Vectors orthogonal to the rays, pointing towards the vertex at matching time, of
        length 1 (model to data) or sqrt(data_to_model_weight) (data to model): the row's
        square-root weight.
    """

    vertex_ids: IntArray
    ray_origins_m: FloatArray
    normals: FloatArray

    @classmethod
    def empty(cls) -> SilhouetteCorrespondences:
        """No matches."""
        return cls(np.zeros(0, dtype=np.int64), np.zeros((0, 3)), np.zeros((0, 3)))

    def scaled(self, factor: float) -> SilhouetteCorrespondences:
        """The same matches with every row multiplied by ``factor``."""
        return SilhouetteCorrespondences(self.vertex_ids, self.ray_origins_m,
                                         factor * self.normals)

    @property
    def n_residuals(self) -> int:
        """Residual count M."""
        return int(self.vertex_ids.shape[0])


def nearest_foreground(features: CameraFeatures, uv_px: FloatArray, max_distance_px: float
                       ) -> tuple[FloatArray, BoolArray]:
    """Closest foreground pixel of each query within ``max_distance_px``.

    Parameters
    ----------
    features : CameraFeatures
        ``mask`` covers ``roi_px`` (full-image coordinates in and out).
    uv_px : (N, 2) float64
        Query points, finite.
    max_distance_px : float

    Returns
    -------
    pixel_uv_px : (N, 2) float64
        Centre of the closest foreground pixel (0 where not found).
    found : (N,) bool
        A foreground pixel lies within the cap. Queries outside the ROI search from the
        nearest ROI pixel (the returned pixel may then not be the globally closest one).
    """
    n = uv_px.shape[0]
    pixel, found = np.zeros((n, 2)), np.zeros(n, dtype=bool)
    box = _search_window(features.roi_px, uv_px, max_distance_px) if n else None
    if box is None:
        return pixel, found
    wu0, wv0, wu1, wv1 = box
    u0, v0 = features.roi_px[:2]
    window = features.mask[wv0 - v0:wv1 - v0, wu0 - u0:wu1 - u0]
    fg = np.flatnonzero(window)
    if fg.size == 0:
        return pixel, found
    # distanceTransform measures the distance to the nearest zero pixel: foreground -> 0.
    # With DIST_LABEL_PIXEL the zero pixels are labelled 1..K in raster order.
    _, labels = cv2.distanceTransformWithLabels(
        np.where(window, 0, 255).astype(np.uint8), cv2.DIST_L2, 5,
        labelType=cv2.DIST_LABEL_PIXEL)
    width = wu1 - wu0
    col = np.clip(np.rint(uv_px[:, 0]).astype(np.int64) - wu0, 0, width - 1)
    row = np.clip(np.rint(uv_px[:, 1]).astype(np.int64) - wv0, 0, wv1 - wv0 - 1)
    flat = fg[labels[row, col] - 1]
    pixel = np.column_stack([flat % width + wu0, flat // width + wv0]).astype(np.float64)
    found = np.hypot(*(pixel - uv_px).T) <= max_distance_px
    return pixel, found


def _search_window(roi_px: tuple[int, int, int, int], uv_px: FloatArray,
                   max_distance_px: float) -> tuple[int, int, int, int] | None:
    """Half-open box ``(u0, v0, u1, v1)``: the queries' bounding box grown by the cap,
    clipped to the ROI; None if empty."""
    u0, v0, u1, v1 = roi_px
    reach = int(np.ceil(max_distance_px)) + 1
    lo = np.floor(uv_px.min(axis=0)).astype(np.int64) - reach
    hi = np.ceil(uv_px.max(axis=0)).astype(np.int64) + reach + 1
    box = (max(int(lo[0]), u0), max(int(lo[1]), v0), min(int(hi[0]), u1), min(int(hi[1]), v1))
    return box if box[2] > box[0] and box[3] > box[1] else None


class SilhouetteEnergy:
    """The 3D silhouette term; see the module docstring.

    Parameters
    ----------
    config : SilhouetteConfig
    """

    name = 'silhouette'

    def __init__(self, config: SilhouetteConfig) -> None:
        self.config = config

    @classmethod
    def from_model(cls, config: SilhouetteConfig, model: Any) -> SilhouetteEnergy:
        """The term for ``model`` (it needs no model tables)."""
        del model
        return cls(config)

    def correspond(self, context: Any) -> SilhouetteCorrespondences:
        """Point-to-ray matches of every camera (model to data, then data to model)."""
        cameras = context.observations.cameras
        if len(cameras) != len(context.views):
            msg = f'{len(context.views)} model views for {len(cameras)} cameras'
            raise ShapeError(msg)
        if not self.config.enabled:
            return SilhouetteCorrespondences.empty()
        parts = [self._model_to_data(context.posed, view, obs)
                 for view, obs in zip(context.views, cameras)]
        if self.config.data_to_model_weight > 0.0:
            root = float(np.sqrt(self.config.data_to_model_weight))
            parts += [self._data_to_model(context.posed, view, obs).scaled(root)
                      for view, obs in zip(context.views, cameras)]
        parts = [p for p in parts if p.n_residuals > 0]
        if not parts:
            return SilhouetteCorrespondences.empty()
        return SilhouetteCorrespondences(np.concatenate([p.vertex_ids for p in parts]),
                                         np.vstack([p.ray_origins_m for p in parts]),
                                         np.vstack([p.normals for p in parts]))

    def residuals(self, posed: Any, correspondences: SilhouetteCorrespondences) -> FloatArray:
        """Signed point-to-ray-plane distances ``r (M,)`` (m)."""
        c = correspondences
        diff = posed.vertices_m[c.vertex_ids] - c.ray_origins_m
        return np.einsum('ni,ni->n', c.normals, diff)

    def linearize(self, posed: Any, correspondences: SilhouetteCorrespondences
                  ) -> tuple[FloatArray, FloatArray]:
        """Residuals ``r (M,)`` (m) and analytic Jacobian ``J (M, P)`` (m per parameter unit)."""
        c = correspondences
        jac = np.einsum('ni,nip->np', c.normals, posed.vertices_jac[c.vertex_ids])
        return self.residuals(posed, c), jac.reshape(c.n_residuals, np.size(posed.theta))

    def jacobian_vertices(self, correspondences: SilhouetteCorrespondences) -> IntArray:
        """Vertex ids (K,) int64 the rows read."""
        return correspondences.vertex_ids

    def _model_to_data(self, posed: Any, view: ModelView, obs: CameraObservation
                       ) -> SilhouetteCorrespondences:
        contours = view.contours
        pick = np.flatnonzero(contours.is_outer)
        pick = pick[_stride(pick.size, self.config.max_points_per_camera)]
        uv = contours.uv_px[pick]
        outside = ~obs.features.mask_at(uv)
        uv, ids = uv[outside], contours.vertex_ids[pick][outside]
        pixel, found = nearest_foreground(obs.features, uv, self.config.max_distance_px)
        offset_px = uv[found] - pixel[found]
        gap = np.linalg.norm(offset_px, axis=1)
        beyond = gap > self.config.tolerance_px
        # The silhouette boundary passes half a pixel beyond the foreground pixel centre.
        target = pixel[found][beyond] + _HALF_PIXEL * offset_px[beyond] / gap[beyond, None]
        return _ray_matches(posed, view.camera, ids[found][beyond], target)

    def _data_to_model(self, posed: Any, view: ModelView, obs: CameraObservation
                       ) -> SilhouetteCorrespondences:
        contours = view.contours
        outer = contours.is_outer
        pixels = obs.features.silhouette_px
        pixels = pixels[~view.raster.mask[pixels[:, 1], pixels[:, 0]]]
        pixels = pixels[_stride(len(pixels), self.config.max_points_per_camera)]
        if not outer.any() or pixels.size == 0:
            return SilhouetteCorrespondences.empty()
        q = pixels.astype(np.float64)
        gap, nearest = nearest_point(q, np.ascontiguousarray(contours.uv_px[outer]),
                                     self.config.max_distance_px)
        hit = np.isfinite(gap) & (gap > self.config.tolerance_px)
        uv = contours.uv_px[outer][nearest[hit]]
        # The silhouette boundary passes half a pixel beyond the pixel centre, away from u.
        target = q[hit] + _HALF_PIXEL * (q[hit] - uv) / gap[hit, None]
        return _ray_matches(posed, view.camera, contours.vertex_ids[outer][nearest[hit]],
                            target)


@numba.njit(cache=True, nogil=True)
def _nearest(queries, points, max_sq):  # pragma: no cover - compiled
    gap = np.full(queries.shape[0], np.inf)
    index = np.full(queries.shape[0], points.shape[0])
    for i in range(queries.shape[0]):
        best = max_sq
        for j in range(points.shape[0]):
            du, dv = points[j, 0] - queries[i, 0], points[j, 1] - queries[i, 1]
            d2 = du * du + dv * dv
            if d2 < best:
                best, index[i] = d2, j
        if index[i] < points.shape[0]:
            gap[i] = math.sqrt(best)
    return gap, index


def nearest_point(queries_px: FloatArray, points_px: FloatArray, max_distance_px: float
                  ) -> tuple[FloatArray, IntArray]:
    """Nearest of ``points_px`` (M, 2) to every query (N, 2), both float64 px.

    Brute force in numba: at most a few hundred contour points against a few hundred
    silhouette pixels per camera and round, where building a k-d tree cost more than the
    whole O(N M) scan (0.25 vs 0.05 ms at 320x240).

    Returns
    -------
    gap_px : (N,) float64
        Distance to the nearest point, ``inf`` when none is closer than ``max_distance_px``
        (the ``cKDTree.query(distance_upper_bound=...)`` convention).
    index : (N,) int64
        Its index into ``points_px``; ``M`` where ``gap_px`` is ``inf``.
    """
    return _nearest(queries_px, points_px, float(max_distance_px) ** 2)


def _stride(n: int, cap: int) -> IntArray:
    """At most ``cap`` evenly spread indices into ``n`` items."""
    if n <= cap:
        return np.arange(n)
    return np.linspace(0, n - 1, cap).astype(np.int64)


def _ray_matches(posed: Any, camera: Any, vertex_ids: IntArray, target_px: FloatArray
                 ) -> SilhouetteCorrespondences:
    """Vertices against the rays through ``target_px``: ``n`` from the ray towards the vertex."""
    if vertex_ids.size == 0:
        return SilhouetteCorrespondences.empty()
    origin, dirs = camera.rays(target_px)
    offset = posed.vertices_m[vertex_ids] - origin
    w = offset - np.einsum('ni,ni->n', offset, dirs)[:, None] * dirs
    dist = np.linalg.norm(w, axis=1)
    keep = dist > _MIN_RAY_DISTANCE_M
    return SilhouetteCorrespondences(vertex_ids[keep], np.repeat(origin[None], keep.sum(), 0),
                                     w[keep] / dist[keep, None])
