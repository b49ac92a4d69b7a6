"""Linear-blend skinning (LBS) of the hand mesh and its analytic pose Jacobian.

With skinning transforms ``A_b = T_b T_b,rest^-1`` (rest hand frame -> posed world) and
weights ``w_vb`` (rows sum to 1), a vertex with rest position ``x_v`` is

    X_v = sum_b w_vb A_b x_v.

Each ``y_vb = A_b x_v`` moves rigidly with bone ``b``, so by the hinge rule of
:mod:`.kinematics`

    dX_v / dtheta_k = sum_{b moved by k} w_vb  a_k x (y_vb - p_k)     (revolute k)
    dX_v / dtheta_k = e_k                                              (translation k)

using that the weights sum to 1. The kernels loop over the (at most 4) influences of each
vertex and the (at most 7) revolute DOF that move that bone, which is far cheaper than the
dense ``(V, B) x (B, P)`` form. They are numba-compiled with ``cache=True`` so the compile
cost (about a second) is paid once per machine, not at every process start, and ``nogil``:
the live tracker's fit shares its process with the feature and detector threads.
"""
from __future__ import annotations

import numba
import numpy as np

from hand_tracker_ros._typing import FloatArray, Int32Array, IntArray


@numba.njit(cache=True, nogil=True)
def _skin(transforms: np.ndarray, rest: np.ndarray, bones: np.ndarray,
          weights: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    n_v, n_i = bones.shape
    out = np.zeros((n_v, 3))
    for v in range(n_v):
        x0, x1, x2 = rest[v, 0], rest[v, 1], rest[v, 2]
        for j in range(n_i):
            w = weights[v, j]
            if w == 0.0:
                continue
            a = transforms[bones[v, j]]
            for r in range(3):
                out[v, r] += w * (a[r, 0] * x0 + a[r, 1] * x1 + a[r, 2] * x2 + a[r, 3])
    return out


@numba.njit(cache=True, nogil=True)
def _skin_jacobian(transforms: np.ndarray, rest: np.ndarray, bones: np.ndarray,
                   weights: np.ndarray, bone_dofs: np.ndarray, axes: np.ndarray,
                   pivots: np.ndarray, n_p: int, rows: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover - compiled
    n_v, n_i = bones.shape
    out = _skin(transforms, rest, bones, weights)
    jac = np.zeros((n_v, 3, n_p))
    y = np.zeros(3)
    for v in rows:
        x0, x1, x2 = rest[v, 0], rest[v, 1], rest[v, 2]
        for r in range(3):
            jac[v, r, r] = 1.0
        for j in range(n_i):
            w = weights[v, j]
            if w == 0.0:
                continue
            b = bones[v, j]
            a = transforms[b]
            for r in range(3):
                y[r] = a[r, 0] * x0 + a[r, 1] * x1 + a[r, 2] * x2 + a[r, 3]
            for m in range(bone_dofs.shape[1]):
                k = bone_dofs[b, m]
                if k < 0:
                    break
                d0, d1, d2 = y[0] - pivots[k, 0], y[1] - pivots[k, 1], y[2] - pivots[k, 2]
                jac[v, 0, k] += w * (axes[k, 1] * d2 - axes[k, 2] * d1)
                jac[v, 1, k] += w * (axes[k, 2] * d0 - axes[k, 0] * d2)
                jac[v, 2, k] += w * (axes[k, 0] * d1 - axes[k, 1] * d0)
    return out, jac


@numba.njit(cache=True, nogil=True)
def _normals(verts: np.ndarray, faces: np.ndarray) -> np.ndarray:  # pragma: no cover
    normals = np.zeros_like(verts)
    for f in range(faces.shape[0]):
        i, j, k = faces[f, 0], faces[f, 1], faces[f, 2]
        a0, a1, a2 = verts[j, 0] - verts[i, 0], verts[j, 1] - verts[i, 1], verts[j, 2]
        b0, b1, b2 = verts[k, 0] - verts[i, 0], verts[k, 1] - verts[i, 1], verts[k, 2]
        a2 -= verts[i, 2]
        b2 -= verts[i, 2]
        n0, n1, n2 = a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0
        for c in range(3):
            vid = faces[f, c]
            normals[vid, 0] += n0
            normals[vid, 1] += n1
            normals[vid, 2] += n2
    for v in range(verts.shape[0]):
        norm = np.sqrt(normals[v, 0] ** 2 + normals[v, 1] ** 2 + normals[v, 2] ** 2)
        if norm > 0.0:
            for c in range(3):
                normals[v, c] /= norm
    return normals


def skin(skinning_transforms: FloatArray, rest_m: FloatArray, bones: IntArray,
         weights: FloatArray) -> FloatArray:
    """Posed vertices (V, 3) float64.

    Parameters
    ----------
    skinning_transforms : (B, 4, 4) float64
        ``A_b = T_b T_b,rest^-1``.
    rest_m : (V, 3) float64
        Rest vertices (hand frame).
    bones, weights : (V, I) int64, (V, I) float64
        Sparse skinning influences.
    """
    return _skin(skinning_transforms, rest_m, bones, weights)


def skin_with_jacobian(skinning_transforms: FloatArray, rest_m: FloatArray, bones: IntArray,
                       weights: FloatArray, bone_dofs: IntArray, axes: FloatArray,
                       pivots: FloatArray, rows: IntArray | None = None
                       ) -> tuple[FloatArray, FloatArray]:
    """Posed vertices (V, 3) and their Jacobian (V, 3, P) float64.

    ``bone_dofs`` (B, D) int64 lists the revolute DOF moving each bone (padded with -1);
    ``axes``/``pivots`` (P, 3) are the world hinge axes and pivots of the current pose.
    ``rows`` (K,) int64, unique, restricts the Jacobian to those vertices (the other rows
    stay zero); the default is every vertex.
    """
    if rows is None:
        rows = np.arange(rest_m.shape[0])
    return _skin_jacobian(skinning_transforms, rest_m, bones, weights, bone_dofs, axes,
                          pivots, axes.shape[0], np.asarray(rows, dtype=np.int64))


def vertex_normals(verts_m: FloatArray, faces: Int32Array) -> FloatArray:
    """Area-weighted unit vertex normals (V, 3) float64 of a mesh (faces (F, 3) int32)."""
    return _normals(verts_m, faces)
