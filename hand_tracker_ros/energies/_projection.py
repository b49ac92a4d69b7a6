r"""Residual rows of projected mesh vertices against fixed 2D targets, with their Jacobian.

Shared by the image terms (edges, flow, salient points). A vertex ``X_i(theta)`` projects to
``u_i = pi_c(X_i(theta))`` in camera ``c``; by the chain rule

.. math::

    \frac{\partial u_i}{\partial \theta} = \frac{\partial \pi_c}{\partial X}(X_i)\,
    \frac{\partial X_i}{\partial \theta}
    \qquad (2 \times 3)(3 \times P)

with ``duv_dX`` from :meth:`PinholeCamera.project_jacobian` and ``dX/dtheta`` the rows
``posed.vertices_jac[ids]``. A block of targets ``t_i`` (px) with square-root weights ``s_i``
gives either

- point rows (``normals_px is None``): ``r = s_i (u_i - t_i)``, 2 rows per target (u then v);
- line rows (unit normals ``n_i`` fixed for the round): ``r = s_i n_i^T (u_i - t_i)``, the
  signed distance (px) of ``u_i`` to the line through ``t_i`` orthogonal to ``n_i``, 1 row.

Residuals are in px. A vertex that moves behind the camera during a trial step projects to
NaN; the optimizer rejects such a step (non-finite cost), so no guard is needed here.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from hand_tracker_ros._typing import FloatArray, IntArray
from hand_tracker_ros.checks import check_finite, check_shape
from hand_tracker_ros.geometry.camera import PinholeCamera


@dataclass(frozen=True, eq=False)
class ImageTargets:
    """2D targets of mesh vertices in one camera, fixed for one correspondence round.

    Attributes
    ----------
    camera : PinholeCamera
    vertex_ids : (N,) int64
        Mesh vertex of each target (repeats allowed).
    targets_px : (N, 2) float64
        Target pixel coordinates.
    sqrt_weights : (N,) float64
        Per-target square-root weights (multiply the residual rows).
    normals_px : (N, 2) float64 or None
        Unit image normals for line rows; None for point rows.
    """

    camera: PinholeCamera
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


def project_vertices(camera: PinholeCamera, posed: Any, vertex_ids: IntArray, *,
                     jacobian: bool = True) -> tuple[FloatArray, FloatArray | None]:
    """Project posed mesh vertices and differentiate them w.r.t. the pose.

    Parameters
    ----------
    camera : PinholeCamera
    posed : PosedHand
        ``vertices_m (V, 3)`` and, if ``jacobian``, ``vertices_jac (V, 3, P)``.
    vertex_ids : (N,) int64
    jacobian : bool

    Returns
    -------
    uv_px : (N, 2) float64
        Projections (NaN behind the camera).
    duv_dtheta : (N, 2, P) float64 or None
        ``d uv / d theta`` (px per parameter unit); None unless ``jacobian``.
    """
    points = posed.vertices_m[vertex_ids]
    if not jacobian:
        return camera.project(points)[0], None
    uv, _, duv_dX = camera.project_jacobian(points)
    return uv, np.einsum('nij,njp->nip', duv_dX, posed.vertices_jac[vertex_ids])


def _block_rows(posed: Any, block: ImageTargets, jacobian: bool
                ) -> tuple[FloatArray, FloatArray | None]:
    s = block.sqrt_weights
    if block.normals_px is None:
        uv, duv = project_vertices(block.camera, posed, block.vertex_ids, jacobian=jacobian)
        r = (s[:, None] * (uv - block.targets_px)).ravel()
        J = None if duv is None else (s[:, None, None] * duv).reshape(-1, duv.shape[2])
        return r, J
    # Point-to-line rows: contract the normal into d(uv)/dX first, n^T (duv/dX) (N, 3), so
    # the chain rule with the (N, 3, P) vertex Jacobian forms no (N, 2, P) intermediate.
    n = block.normals_px
    points = posed.vertices_m[block.vertex_ids]
    if not jacobian:
        uv = block.camera.project(points)[0]
        return s * np.einsum('ni,ni->n', n, uv - block.targets_px), None
    uv, _, duv_dX = block.camera.project_jacobian(points)
    g = s[:, None] * np.einsum('ni,nij->nj', n, duv_dX)
    r = s * np.einsum('ni,ni->n', n, uv - block.targets_px)
    return r, np.einsum('nj,njp->np', g, posed.vertices_jac[block.vertex_ids])


def image_residuals(posed: Any, blocks: Sequence[ImageTargets]) -> FloatArray:
    """Stacked residuals ``r (M,)`` (px) of all blocks, in block order."""
    rows = [_block_rows(posed, b, False)[0] for b in blocks]
    return np.concatenate(rows) if rows else np.zeros(0)


def image_linearize(posed: Any, blocks: Sequence[ImageTargets]
                    ) -> tuple[FloatArray, FloatArray]:
    """Stacked residuals ``r (M,)`` (px) and Jacobian ``J (M, P)`` (px per parameter unit)."""
    n_params = int(np.size(posed.theta))
    parts = [_block_rows(posed, b, True) for b in blocks if b.n_rows > 0]
    if not parts:
        return np.zeros(0), np.zeros((0, n_params))
    return (np.concatenate([r for r, _ in parts]),
            np.vstack([J for _, J in parts]))
