r"""Residual rows of projected mesh vertices against fixed 2D targets, with their Jacobian.

Shared by the image terms (edges, flow, salient points). A vertex ``X_i(theta)`` projects to
``u_i = pi_c(X_i(theta))`` in camera ``c``; by the chain rule

.. math::

    \frac{\partial u_i}{\partial \theta} = \frac{\partial \pi_c}{\partial X}(X_i)\,
    \frac{\partial X_i}{\partial \theta}
    \qquad (2 \times 3)(3 \times P)

with ``duv_dX`` from :meth:`Camera.project_jacobian` (distortion included) and
``dX/dtheta`` the rows ``posed.vertices_jac[ids]``. For a :class:`PinholeCamera` one numba pass
per block projects, contracts with the normal and forms the rows without (N, 2, 3) or
(N, 2, P) temporaries; any other camera model goes through its ``project_jacobian`` and two
contractions (the same rows, slower).
A block of targets ``t_i`` (px) with square-root weights ``s_i`` gives either

- point rows (``normals_px is None``): ``r = s_i (u_i - t_i)``, 2 rows per target (u then v);
- line rows (unit normals ``n_i`` fixed for the round): ``r = s_i n_i^T (u_i - t_i)``, the
  signed distance (px) of ``u_i`` to the line through ``t_i`` orthogonal to ``n_i``, 1 row.

Residuals are in px. A vertex that moves behind the camera during a trial step projects to
NaN; the optimizer rejects such a step (non-finite cost), so no guard is needed here.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numba
import numpy as np

from hand_tracker_ros._typing import FloatArray, IntArray
from hand_tracker_ros.checks import check_finite, check_shape
from hand_tracker_ros.geometry.camera import PinholeCamera, distort_point, pixel_jacobian
from hand_tracker_ros.geometry.camera_model import Camera
from hand_tracker_ros.model.hand import PosedHand


@dataclass(frozen=True, eq=False)
class ImageTargets:
    """2D targets of mesh vertices in one camera, fixed for one correspondence round.

    Attributes
    ----------
    camera : Camera
    vertex_ids : (N,) int64
        Mesh vertex of each target (repeats allowed).
    targets_px : (N, 2) float64
        Target pixel coordinates.
    sqrt_weights : (N,) float64
        Per-target square-root weights (multiply the residual rows).
    normals_px : (N, 2) float64 or None
        Unit image normals for line rows; None for point rows.
    """

    camera: Camera
    vertex_ids: IntArray
    targets_px: FloatArray
    sqrt_weights: FloatArray
    normals_px: FloatArray | None = None

    def __post_init__(self) -> None:
        check_shape('vertex_ids', self.vertex_ids, (None,))
        n = self.vertex_ids.shape[0]
        check_shape('targets_px', self.targets_px, (n, 2))
        check_shape('sqrt_weights', self.sqrt_weights, (n,))
        check_finite('targets_px', self.targets_px)
        check_finite('sqrt_weights', self.sqrt_weights)
        if self.normals_px is not None:
            check_shape('normals_px', self.normals_px, (n, 2))
            check_finite('normals_px', self.normals_px)

    @property
    def n_rows(self) -> int:
        """Residual rows of this block: N for line rows, 2 N for point rows."""
        n = int(self.vertex_ids.shape[0])
        return n if self.normals_px is not None else 2 * n


@numba.njit(cache=True, nogil=True)
def _rows(vertices: np.ndarray, vertices_jac: np.ndarray, ids: np.ndarray, R: np.ndarray,
          t: np.ndarray, intrinsics: np.ndarray, dist8: np.ndarray, targets: np.ndarray,
          s: np.ndarray, normals: np.ndarray, line: bool, jacobian: bool
          ) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover - compiled
    """Rows of one block: project, distort, chain rule and weight per target in one pass.

    numba because the numpy form (``PinholeCamera.project_jacobian`` then two einsums per
    block) spends most of its time in dispatch and temporaries of a few thousand rows, and it
    runs once per camera and term at every LM evaluation. The distortion and its derivative
    are the camera module's kernels (the test compares the rows with
    :meth:`PinholeCamera.project_jacobian` and the chain rule).
    """
    n, n_p = ids.shape[0], vertices_jac.shape[2]
    per = 1 if line else 2
    r = np.empty(n * per)
    J = np.zeros((n * per if jacobian else 0, n_p))
    fx, fy, cx, cy = intrinsics[0], intrinsics[1], intrinsics[2], intrinsics[3]
    g = np.empty((2, 3))
    pc = np.empty(3)
    for i in range(n):
        v = ids[i]
        for a in range(3):
            pc[a] = (R[a, 0] * vertices[v, 0] + R[a, 1] * vertices[v, 1]
                     + R[a, 2] * vertices[v, 2] + t[a])
        inv_z = 1.0 / pc[2] if pc[2] > 0.0 else np.nan
        x, y = pc[0] * inv_z, pc[1] * inv_z
        xd, yd, f, r2, num, den = distort_point(x, y, dist8)
        du = fx * xd + cx - targets[i, 0]
        dv = fy * yd + cy - targets[i, 1]
        if line:
            r[i] = s[i] * (normals[i, 0] * du + normals[i, 1] * dv)
        else:
            r[2 * i], r[2 * i + 1] = s[i] * du, s[i] * dv
        if not jacobian:
            continue
        pixel_jacobian(x, y, inv_z, f, r2, num, den, fx, fy, R, dist8, g)
        for c in range(3):   # weighted
            g[0, c] = s[i] * g[0, c]
            g[1, c] = s[i] * g[1, c]
        if line:
            for c in range(3):
                g[0, c] = normals[i, 0] * g[0, c] + normals[i, 1] * g[1, c]
        for row in range(per):
            for c in range(3):
                gc = g[row, c]
                for k in range(n_p):
                    J[per * i + row, k] += gc * vertices_jac[v, c, k]
    return r, J


def _block_rows(posed: PosedHand, block: ImageTargets, jacobian: bool
                ) -> tuple[FloatArray, FloatArray | None]:
    camera = block.camera
    if not isinstance(camera, PinholeCamera):
        return _camera_rows(posed, block, camera, jacobian)
    line = block.normals_px is not None
    normals = block.normals_px if block.normals_px is not None else np.zeros((0, 2))
    jac = posed.vertices_jac if jacobian else np.zeros((0, 3, int(np.size(posed.theta))))
    assert jac is not None, 'posed without its Jacobian'
    intrinsics = np.array([camera.K[0, 0], camera.K[1, 1], camera.K[0, 2], camera.K[1, 2]])
    r, J = _rows(posed.vertices_m, jac, block.vertex_ids, camera.R_cam_world,
                 camera.T_cam_world[:3, 3], intrinsics, camera.dist8, block.targets_px,
                 block.sqrt_weights, normals, line, jacobian)
    return r, (J if jacobian else None)


def _camera_rows(posed: PosedHand, block: ImageTargets, camera: Camera, jacobian: bool
                 ) -> tuple[FloatArray, FloatArray | None]:
    """The rows of :func:`_rows` for any :class:`Camera`, from its ``project_jacobian``."""
    ids = block.vertex_ids
    s = block.sqrt_weights
    uv, _, duv_dX = camera.project_jacobian(posed.vertices_m[ids])
    diff = uv - block.targets_px                                   # (N, 2) px
    if block.normals_px is not None:                               # line rows, 1 per target
        n = block.normals_px
        r = s * np.einsum('nk,nk->n', n, diff)
        g = s[:, None, None] * np.einsum('nk,nkc->nc', n, duv_dX)[:, None, :]   # (N, 1, 3)
    else:                                                          # point rows, u then v
        r = (s[:, None] * diff).ravel()
        g = s[:, None, None] * duv_dX                              # (N, 2, 3)
    if not jacobian:
        return r, None
    assert posed.vertices_jac is not None, 'posed without its Jacobian'
    J = np.einsum('nrc,ncp->nrp', g, posed.vertices_jac[ids]).reshape(r.size, -1)
    return r, J


def block_vertices(blocks: Sequence[ImageTargets]) -> IntArray:
    """Vertex ids (K,) int64 the blocks' rows read (the ``Energy.jacobian_vertices`` of the
    image terms)."""
    return np.concatenate([np.zeros(0, np.int64)] + [b.vertex_ids for b in blocks])


def image_residuals(posed: PosedHand, blocks: Sequence[ImageTargets]) -> FloatArray:
    """Stacked residuals ``r (M,)`` (px) of all blocks, in block order."""
    rows = [_block_rows(posed, b, False)[0] for b in blocks]
    return np.concatenate(rows) if rows else np.zeros(0)


def image_linearize(posed: PosedHand, blocks: Sequence[ImageTargets]
                    ) -> tuple[FloatArray, FloatArray]:
    """Stacked residuals ``r (M,)`` (px) and Jacobian ``J (M, P)`` (px per parameter unit)."""
    n_params = int(np.size(posed.theta))
    parts = [_block_rows(posed, b, True) for b in blocks if b.n_rows > 0]
    if not parts:
        return np.zeros(0), np.zeros((0, n_params))
    jacobians = []
    for _, J in parts:
        assert J is not None    # linearized with jacobian=True
        jacobians.append(J)
    return np.concatenate([r for r, _ in parts]), np.vstack(jacobians)
