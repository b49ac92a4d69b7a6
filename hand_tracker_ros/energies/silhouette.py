r"""Sil, the silhouette term in 3D (the second seed: docs/references.md).

Model points that project outside the observed hand silhouette are pulled, in 3D, onto the
camera rays through their closest data-silhouette pixels:

.. math:: E_S = \sum_{m \in M} \| n^T (m - p) \|^2

Correspondences (once per round, per camera). The model silhouette points ``m`` are the
OUTER contour vertices of the view (``ModelView.contours`` with ``is_outer``), thinned to at
most ``max_points_per_camera`` by an even stride. Those whose projection ``u`` lies outside
the observed foreground mask (``CameraFeatures.mask_at``) are matched, in 2D, to the closest
foreground pixel ``q`` (for a point outside the mask the closest foreground pixel is a
silhouette pixel) by ``cv2.distanceTransformWithLabels`` of the mask's complement, computed
once per frame (``CameraFeatures.nearest_foreground``). Matches farther than
``max_distance_px`` are dropped, and so are points within ``tolerance_px`` of the pixel
centre: a silhouette vertex rounds to a background pixel half the time although it lies on
the boundary, and matching it would shrink the model by the mask quantisation. The
silhouette boundary itself passes half a pixel from the pixel centre towards ``u``, so the
target is ``t = q + 0.5 (u - q) / |u - q|``, which defines the ray ``p + s d`` (``p`` the camera
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

A camera whose mask floods the hand gives no data-to-model rows. When the observed
foreground in the model's bounding box, grown by ``data_to_model_reach`` of its size on every
side, is more than ``data_to_model_max_foreground`` times the model's silhouette area, the
mask does not delineate the hand there: a skin-coloured background merges with it, and the
boundary of that background, where it passes near the hand, would pull the nearest fingers
to it. (Its model-to-data rows stay: with the hand inside the foreground they are few.) On
the synthetic bags about one camera in four has foreground over three times the hand's area
around it at the first frame (smooth-noise backgrounds of random colours). Measured on 50
bags (seeds 3301-3319, 3431-3440, 3451-3471; true shape) by fitting every tenth frame from
its true pose, the previous frame at its truth: mean error after the fit 1.48 -> 1.41 mm, 12
bags better by more than 0.1 mm, none worse. Keeping instead the rows of uncovered
foreground components that stay small and inside the grown box, in every camera, gave 1.47
(9 better, 9 worse): it also dropped rows of clean cameras, and left the flooded cameras'
rows of small foreground islands near the hand.

Data-to-model rows are checked against the other views (``data_to_model_views``). Skin-
coloured clutter touching the hand in one camera is uncovered foreground there, and its rows
pull the nearest fingers into it (random motion with 40 clutter shapes, seed 202, 150 frames:
11.6 mm mean with these rows, 3.2 mm without them). A hand pixel's ray passes through the
hand, which every camera sees as foreground (the visual hull); a clutter pixel's ray, near the
hand's depth, lands on background in the other cameras. So a row is kept only when ``X``, the
point of the pixel's ray nearest to its model point ``m``, projects within
``data_to_model_views_px`` of foreground in every other camera whose observed window (the
image or its region of interest) contains the projection. ``X`` is at the model's depth, not
the finger's, hence the tolerance.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from hand_tracker_ros._typing import BoolArray, FloatArray, IntArray
from hand_tracker_ros.config import param
from hand_tracker_ros.core.context import RoundContext
from hand_tracker_ros.core.observations import CameraObservation, FrameObservations
from hand_tracker_ros.core.views import ModelView
from hand_tracker_ros.errors import ShapeError
from hand_tracker_ros.model.hand import HandModel, PosedHand
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
    data_to_model_reach: float = param(
        0.5, 'a camera\'s foreground is measured in the model\'s bounding box grown by this '
        'fraction of its size on every side', low=0.0, high=10.0)
    data_to_model_max_foreground: float = param(
        2.0, 'a camera with more foreground there than this many times the model\'s '
        'silhouette area floods the hand and gives no data-to-model rows', low=1.0,
        high=1000.0)
    data_to_model_views: bool = param(
        True, 'use a data-to-model pixel only where the other cameras agree: the point of its '
        'ray nearest to its model point lies within data_to_model_views_px of the foreground '
        'in every other camera that observes it')
    data_to_model_views_px: int = param(3, 'tolerance of that test', unit='px', low=0,
                                        high=50)


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

    @property
    def n_residuals(self) -> int:
        """Residual count M."""
        return int(self.vertex_ids.shape[0])


def outside_targets(features: CameraFeatures, uv_px: FloatArray, max_distance_px: float,
                    tolerance_px: float) -> tuple[BoolArray, FloatArray]:
    """Model-to-data targets: the silhouette boundary nearest to each point outside the mask.

    A query is matched when its nearest pixel is background (``CameraFeatures.mask_at``), the
    closest foreground pixel ``q`` (``CameraFeatures.nearest_foreground``; queries outside
    its window search from the nearest window pixel) lies within ``max_distance_px`` and
    farther than ``tolerance_px``. Its target is ``t = q + 0.5 (u - q) / |u - q|``.

    Parameters
    ----------
    features : CameraFeatures
        ``mask`` covers ``roi_px`` (full-image coordinates in and out).
    uv_px : (N, 2) float64
        Query points, finite.
    max_distance_px, tolerance_px : float

    Returns
    -------
    matched : (N,) bool
    target_px : (N, 2) float64
        ``t`` where matched, 0 elsewhere.
    """
    nearest = features.nearest_foreground(_reach_px(max_distance_px))
    return _outside_targets(np.ascontiguousarray(uv_px, dtype=np.float64), nearest.index,
                            nearest.window_px[0], nearest.window_px[1],
                            float(max_distance_px), float(tolerance_px))


def _reach_px(max_distance_px: float) -> int:
    """Window margin (px) of the nearest-foreground lookup of :func:`outside_targets`."""
    return int(np.ceil(max_distance_px)) + 1


# Hand-written instead of numpy: the mask test, the nearest-pixel lookup and the target were
# a dozen numpy calls with their temporaries per camera and round for a few hundred points
# (0.6 -> 0.05 ms per camera); the test compares it with the numpy form.
@numba.njit(cache=True, nogil=True)
def _outside_targets(uv: np.ndarray, nearest: np.ndarray, u0: int, v0: int, max_distance: float,
                     tolerance: float) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover
    height, width = nearest.shape
    matched = np.zeros(uv.shape[0], dtype=np.bool_)
    target = np.zeros((uv.shape[0], 2))
    for i in range(uv.shape[0] if nearest.size else 0):   # nothing to match in an empty mask
        col, row = int(np.rint(uv[i, 0])) - u0, int(np.rint(uv[i, 1])) - v0
        if 0 <= col < width and 0 <= row < height and nearest[row, col] == row * width + col:
            continue                    # inside the mask (none lies outside the window)
        flat = nearest[min(max(row, 0), height - 1), min(max(col, 0), width - 1)]
        pu, pv = float(flat % width + u0), float(flat // width + v0)
        du, dv = uv[i, 0] - pu, uv[i, 1] - pv
        if math.hypot(pu - uv[i, 0], pv - uv[i, 1]) > max_distance:
            continue
        gap = math.sqrt(du * du + dv * dv)
        if gap > tolerance:
            # The silhouette boundary passes half a pixel beyond the foreground pixel centre.
            matched[i] = True
            target[i, 0] = pu + _HALF_PIXEL * du / gap
            target[i, 1] = pv + _HALF_PIXEL * dv / gap
    return matched, target


@numba.njit(cache=True, nogil=True)
def _near_foreground(mask: np.ndarray, u0: int, v0: int, uv: np.ndarray, radius: int,
                     keep: np.ndarray) -> None:  # pragma: no cover - compiled
    """Clear ``keep[i]`` where ``uv[i]`` (full-image px) falls inside the mask window
    (origin ``u0, v0``) with no foreground pixel within ``radius`` (a square); points outside
    the window or behind the camera (NaN) are not judged."""
    height, width = mask.shape
    for i in range(uv.shape[0]):
        if not keep[i] or not (math.isfinite(uv[i, 0]) and math.isfinite(uv[i, 1])):
            continue
        col, row = int(np.rint(uv[i, 0])) - u0, int(np.rint(uv[i, 1])) - v0
        if col < 0 or col >= width or row < 0 or row >= height:
            continue
        found = False
        for r in range(max(row - radius, 0), min(row + radius + 1, height)):
            for c in range(max(col - radius, 0), min(col + radius + 1, width)):
                if mask[r, c]:
                    found = True
                    break
            if found:
                break
        keep[i] = found


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
    def from_model(cls, config: SilhouetteConfig, model: HandModel) -> SilhouetteEnergy:
        """The term for ``model`` (it needs no model tables)."""
        del model
        return cls(config)

    @property
    def weight(self) -> float:
        """Weight of the term's cost ``0.5 * weight * |r|^2``."""
        return self.config.weight

    def prepare(self, observations: FrameObservations) -> None:
        """The masks' lookups every round reads (``CameraFeatures.nearest_foreground`` and
        ``silhouette_px``, cached per frame; 0.6 ms per 320x240 camera), so that the thread
        observing a set computes them rather than the first round of its fit."""
        if not self.config.enabled:
            return
        for obs in observations.cameras:
            obs.features.nearest_foreground(_reach_px(self.config.max_distance_px))
            if self.config.data_to_model_weight > 0.0:
                obs.features.silhouette_px  # noqa: B018 - fills the cached property

    def correspond(self, context: RoundContext) -> SilhouetteCorrespondences:
        """Point-to-ray matches of every camera (model to data, then data to model)."""
        cameras = context.observations.cameras
        if len(cameras) != len(context.views):
            msg = f'{len(context.views)} model views for {len(cameras)} cameras'
            raise ShapeError(msg)
        if not self.config.enabled:
            return SilhouetteCorrespondences.empty()
        pairs = [self._model_to_data(view, obs) for view, obs in zip(context.views, cameras)]
        scales = [1.0] * len(pairs)
        if self.config.data_to_model_weight > 0.0:
            pairs += [self._data_to_model(view, obs)
                      for view, obs in zip(context.views, cameras)]
            scales += [float(np.sqrt(self.config.data_to_model_weight))] * len(cameras)
        # One back-projection per camera for both directions, one ray fit for all rows.
        n_cam = len(cameras)
        origins: list[FloatArray] = [np.zeros((0, 3))] * len(pairs)   # each set below
        dirs: list[FloatArray] = [np.zeros((0, 3))] * len(pairs)
        for c, view in enumerate(context.views):
            blocks = pairs[c::n_cam]
            origin, rays = view.camera.rays(np.vstack([target for _, target in blocks]))
            bounds = np.cumsum([0] + [len(ids) for ids, _ in blocks])
            for k, (lo, hi) in enumerate(zip(bounds[:-1], bounds[1:])):
                origins[c + k * n_cam] = np.repeat(origin[None], hi - lo, 0)
                dirs[c + k * n_cam] = rays[lo:hi]
        if self.config.data_to_model_weight > 0.0 and self.config.data_to_model_views:
            for k in range(n_cam, 2 * n_cam):
                keep = self._seen_by_the_others(context, k - n_cam, pairs[k][0], origins[k],
                                                dirs[k])
                pairs[k] = (pairs[k][0][keep], pairs[k][1][keep])
                origins[k], dirs[k] = origins[k][keep], dirs[k][keep]
        return _ray_matches(context.posed, np.concatenate([ids for ids, _ in pairs]),
                            np.vstack(origins), np.vstack(dirs),
                            np.repeat(scales, [len(ids) for ids, _ in pairs]))

    def _seen_by_the_others(self, context: RoundContext, camera: int, ids: IntArray,
                            origins_m: FloatArray, dirs: FloatArray) -> BoolArray:
        """Which data-to-model rows (N,) of ``camera`` the other cameras' masks support.

        ``ids`` (N,) model vertices, ``origins_m``, ``dirs`` (N, 3) their rays (module
        docstring, data to model).
        """
        keep = np.ones(len(ids), dtype=bool)
        if not len(ids):
            return keep
        offset = context.posed.vertices_m[ids] - origins_m
        nearest_m = origins_m + np.einsum('ni,ni->n', offset, dirs)[:, None] * dirs
        for other, (view, obs) in enumerate(zip(context.views,
                                                context.observations.cameras)):
            if other == camera or obs.features is None:
                continue
            uv, _ = view.camera.project(nearest_m)
            features = obs.features
            _near_foreground(features.mask, features.roi_px[0], features.roi_px[1], uv,
                             int(self.config.data_to_model_views_px), keep)
        return keep

    def residuals(self, posed: PosedHand, correspondences: SilhouetteCorrespondences
                  ) -> FloatArray:
        """Signed point-to-ray-plane distances ``r (M,)`` (m)."""
        c = correspondences
        diff = posed.vertices_m[c.vertex_ids] - c.ray_origins_m
        return np.einsum('ni,ni->n', c.normals, diff)

    def linearize(self, posed: PosedHand, correspondences: SilhouetteCorrespondences
                  ) -> tuple[FloatArray, FloatArray]:
        """Residuals ``r (M,)`` (m) and analytic Jacobian ``J (M, P)`` (m per parameter unit)."""
        c = correspondences
        assert posed.vertices_jac is not None, 'posed without its Jacobian'
        jac = np.einsum('ni,nip->np', c.normals, posed.vertices_jac[c.vertex_ids])
        return self.residuals(posed, c), jac.reshape(c.n_residuals, np.size(posed.theta))

    def jacobian_vertices(self, correspondences: SilhouetteCorrespondences) -> IntArray:
        """Vertex ids (K,) int64 the rows read."""
        return correspondences.vertex_ids

    def _model_to_data(self, view: ModelView, obs: CameraObservation
                       ) -> tuple[IntArray, FloatArray]:
        """Vertex ids (K,) int64 and ray targets (K, 2) float64 px of one camera."""
        contours = view.contours
        pick = np.flatnonzero(contours.is_outer)
        pick = pick[_stride(pick.size, self.config.max_points_per_camera)]
        matched, target = outside_targets(obs.features, contours.uv_px[pick],
                                          self.config.max_distance_px, self.config.tolerance_px)
        return contours.vertex_ids[pick][matched], target[matched]

    def _data_to_model(self, view: ModelView, obs: CameraObservation
                       ) -> tuple[IntArray, FloatArray]:
        """Vertex ids (K,) int64 and ray targets (K, 2) float64 px of one camera."""
        contours = view.contours
        outer = contours.is_outer
        if not outer.any() or floods(view, obs.features, self.config.data_to_model_reach,
                                     self.config.data_to_model_max_foreground):
            return np.zeros(0, dtype=np.int64), np.zeros((0, 2))
        pixels = obs.features.silhouette_px
        pixels = pixels[~view.raster.mask[pixels[:, 1], pixels[:, 0]]]
        pixels = pixels[_stride(len(pixels), self.config.max_points_per_camera)]
        if pixels.size == 0:
            return np.zeros(0, dtype=np.int64), np.zeros((0, 2))
        q = pixels.astype(np.float64)
        gap, nearest = nearest_point(q, np.ascontiguousarray(contours.uv_px[outer]),
                                     self.config.max_distance_px)
        hit = np.isfinite(gap) & (gap > self.config.tolerance_px)
        uv = contours.uv_px[outer][nearest[hit]]
        # The silhouette boundary passes half a pixel beyond the pixel centre, away from u.
        target = q[hit] + _HALF_PIXEL * (q[hit] - uv) / gap[hit, None]
        return contours.vertex_ids[outer][nearest[hit]], target


def floods(view: ModelView, features: CameraFeatures, reach: float, max_ratio: float) -> bool:
    """Whether the observed foreground floods the hand in one camera (module docstring, data
    to model): in the model's bounding box grown by ``reach`` of its size per side (within
    the image and the mask's region of interest), more than ``max_ratio`` times the model's
    silhouette area (px)."""
    outline = view.contours.uv_px[view.contours.is_outer]
    # Column by column, as in tracking/roi.py: numpy's reductions along axis 0 of an (N, 2)
    # array cost about 20 of this test's 40 us per camera and round.
    u, v = outline[:, 0], outline[:, 1]
    seen = np.isfinite(u) & np.isfinite(v)
    u, v = u[seen], v[seen]
    if not u.size:
        return False
    lo_u, lo_v, hi_u, hi_v = u.min(), v.min(), u.max(), v.max()
    grow_u, grow_v = reach * (hi_u - lo_u), reach * (hi_v - lo_v)
    fu0, fv0, fu1, fv1 = features.roi_px
    u0, v0 = max(int(lo_u - grow_u), fu0), max(int(lo_v - grow_v), fv0)
    u1, v1 = min(int(hi_u + grow_u) + 1, fu1), min(int(hi_v + grow_v) + 1, fv1)
    if u1 <= u0 or v1 <= v0:
        return False
    foreground = np.count_nonzero(features.mask[v0 - fv0:v1 - fv0, u0 - fu0:u1 - fu0])
    return bool(foreground > max_ratio * np.count_nonzero(view.raster.mask))


@numba.njit(cache=True, nogil=True)
def _nearest(queries: np.ndarray, points: np.ndarray,
             max_sq: float) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover - compiled
    # Points sorted by u: a query scans only those within the reach in u. Among equally near
    # points the lowest index wins, as in a scan of all of them in order.
    order = np.argsort(points[:, 0], kind='mergesort')
    su = points[order, 0]
    reach = math.sqrt(max_sq) * (1.0 + 1e-9) + 1e-9     # a prefilter: a little wide is exact
    gap = np.full(queries.shape[0], np.inf)
    index = np.full(queries.shape[0], points.shape[0])
    for i in range(queries.shape[0]):
        best, pick = max_sq, points.shape[0]
        lo = np.searchsorted(su, queries[i, 0] - reach, side='left')
        hi = np.searchsorted(su, queries[i, 0] + reach, side='right')
        for k in range(lo, hi):
            j = order[k]
            du, dv = points[j, 0] - queries[i, 0], points[j, 1] - queries[i, 1]
            d2 = du * du + dv * dv
            if d2 < best or (d2 == best and j < pick and pick < points.shape[0]):
                best, pick = d2, j
        if pick < points.shape[0]:
            index[i], gap[i] = pick, math.sqrt(best)
    return gap, index


def nearest_point(queries_px: FloatArray, points_px: FloatArray, max_distance_px: float
                  ) -> tuple[FloatArray, IntArray]:
    """Nearest of ``points_px`` (M, 2) to every query (N, 2), both float64 px.

    A scan in numba over the points sorted by ``u``, each query visiting those within
    ``max_distance_px`` in ``u``: at most a few hundred contour points against a few hundred
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


def _ray_matches(posed: PosedHand, vertex_ids: IntArray, origins_m: FloatArray, dirs: FloatArray,
                 scale: FloatArray) -> SilhouetteCorrespondences:
    """Vertices (M,) against the rays ``origins_m (M, 3) + s dirs (M, 3)`` (unit directions):
    ``n`` from the ray towards the vertex, times the row weight ``scale (M,)``."""
    if vertex_ids.size == 0:
        return SilhouetteCorrespondences.empty()
    offset = posed.vertices_m[vertex_ids] - origins_m
    w = offset - np.einsum('ni,ni->n', offset, dirs)[:, None] * dirs
    dist = np.linalg.norm(w, axis=1)
    keep = dist > _MIN_RAY_DISTANCE_M
    return SilhouetteCorrespondences(vertex_ids[keep], origins_m[keep],
                                     scale[keep, None] * (w[keep] / dist[keep, None]))
