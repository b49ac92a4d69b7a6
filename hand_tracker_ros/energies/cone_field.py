"""The cone distance field of Ballan et al. 2012 (supplementary, Eqs. 1-3), with gradients.

A *receiver* triangle ``(p0, p1, p2)`` carries a cone: origin at the barycentre
``o = (p0 + p1 + p2) / 3``, axis the unit normal ``n = m / |m|`` with
``m = (p1 - p0) x (p2 - p0)``, and radius ``r = max_k |p_k - o|`` at the triangle's plane (the
circle centred at ``o`` circumscribing the triangle). The apex lies in front of the face at
height ``+sigma``; the cone widens without bound behind it (inside the mesh). For a point ``v``
with ``d = v - o``::

    x = n . d                        (height over the face plane)
    s = |d - x n|                    (distance to the cone axis)
    Phi(v) = s / (r - (r / sigma) x)                                    (Eq. 2)
    Upsilon(x) = -x + 1 - sigma                         x <= -sigma
               = -(1 - 2 sigma) / (4 sigma^2) x^2 - x / (2 sigma) + (3 - 2 sigma) / 4
                                                        -sigma <= x <= sigma     (Eq. 3)
               = 0                                      x >= sigma
    Psi(v) = |(1 - Phi(v)) Upsilon(x)|^2  if Phi(v) < 1 else 0          (Eq. 1)

Upsilon is continuous (1 at ``-sigma``, 0 at ``+sigma``) and C1 at ``-sigma`` (slope -1).
The apex is handled explicitly: where the denominator ``D = r (1 - x / sigma)`` is ``<= 0``
(``x >= sigma``) the point is outside the cone and ``Psi = 0``; so is every point of a
zero-area receiver (no normal, no cone).

The least-squares residual is ``rho = (1 - Phi) Upsilon(x)`` inside the cone and 0 outside,
so ``rho^2 = Psi``. Its gradient, with ``w = d - x n`` (``s = |w|``)::

    drho/ds = -Upsilon / D
    drho/dx = (1 - Phi) Upsilon'(x) - Upsilon s r / (sigma D^2)      (s, r held fixed)
    drho/dr = Upsilon Phi / r
    drho/dd = drho/ds w / s + drho/dx n
    drho/dn = -drho/ds x d / s + drho/dx d                             (n held unnormalised)

and it is chained to the triangle's vertices through ``o`` (``-drho/dd / 3`` each), through
``n = m / |m|`` (``g_m = (I - n n^T) g_n / |m|``; ``g_p1 = e2 x g_m``, ``g_p2 = g_m x e1``,
``g_p0 = -(g_p1 + g_p2)``) and through the active vertex ``k`` of the max in ``r``
(``dr/dp_j = (delta_jk - 1/3) u``, ``u = (p_k - o) / r``). On the cone axis (``s = 0``) the
direction ``w / s`` is undefined; the subgradient 0 is used there.

Units: every length (points, triangles, ``sigma``) is in the same unit; this module is
unit-agnostic. :mod:`hand_tracker_ros.energies.collision` scales metres to model units.

References: docs/references.md.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hand_tracker_ros._typing import BoolArray, FloatArray, IntArray


@dataclass(frozen=True, slots=True)
class ConeGeometry:
    """Cones of N receiver triangles and the coordinates of N points in them.

    Attributes
    ----------
    origin : (N, 3) float64
        Barycentres ``o``.
    normal : (N, 3) float64
        Unit normals ``n`` (right-hand rule on the vertex order).
    cross_norm : (N,) float64
        ``|m|``, twice the triangle area.
    radius : (N,) float64
        Circumscribing radius ``r`` about ``o``.
    active : (N,) int64
        Vertex (0..2) realising the max in ``r``.
    offset : (N, 3) float64
        ``d = v - o``.
    height : (N,) float64
        ``x = n . d``.
    axial : (N,) float64
        ``s``, distance of the point to the cone axis.
    """

    origin: FloatArray
    normal: FloatArray
    cross_norm: FloatArray
    radius: FloatArray
    active: IntArray
    offset: FloatArray
    height: FloatArray
    axial: FloatArray


def cone_geometry(points: FloatArray, triangles: FloatArray) -> ConeGeometry:
    """Cone frames of ``triangles`` and the cone coordinates of ``points``.

    Parameters
    ----------
    points : (N, 3) float64
        Points ``v``, one per triangle.
    triangles : (N, 3, 3) float64
        Receiver triangles, ``triangles[i, k]`` is vertex ``k`` of triangle ``i``.
    """
    origin = triangles.mean(axis=1)
    cross = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    cross_norm = np.linalg.norm(cross, axis=1)
    normal = cross / np.where(cross_norm > 0.0, cross_norm, 1.0)[:, None]
    spokes = np.linalg.norm(triangles - origin[:, None, :], axis=2)
    active = np.argmax(spokes, axis=1)
    radius = spokes[np.arange(len(spokes)), active]
    offset = points - origin
    height = np.einsum('ij,ij->i', normal, offset)
    tangential = offset - height[:, None] * normal
    axial = np.linalg.norm(tangential, axis=1)
    return ConeGeometry(origin, normal, cross_norm, radius, active.astype(np.int64), offset,
                        height, axial)


def upsilon(x: FloatArray, sigma: float) -> FloatArray:
    """Depth profile ``Upsilon(x)`` (Eq. 3), (N,) float64 for ``x`` (N,) float64."""
    quad = (-(1.0 - 2.0 * sigma) / (4.0 * sigma ** 2) * x ** 2 - x / (2.0 * sigma)
            + 0.25 * (3.0 - 2.0 * sigma))
    return np.where(x <= -sigma, -x + 1.0 - sigma, np.where(x >= sigma, 0.0, quad))


def upsilon_derivative(x: FloatArray, sigma: float) -> FloatArray:
    """``dUpsilon/dx`` (N,) float64; the one-sided value from below at ``x = +sigma``."""
    quad = -(1.0 - 2.0 * sigma) / (2.0 * sigma ** 2) * x - 1.0 / (2.0 * sigma)
    return np.where(x <= -sigma, -1.0, np.where(x > sigma, 0.0, quad))


def _denominator(geom: ConeGeometry, sigma: float) -> FloatArray:
    return geom.radius * (1.0 - geom.height / sigma)


def phi(geom: ConeGeometry, sigma: float) -> FloatArray:
    """Radial ratio ``Phi`` (Eq. 2), (N,) float64.

    ``+inf`` at and beyond the apex, and for a zero-area receiver (no cone: no penalty).
    """
    den = _denominator(geom, sigma)
    inside = (den > 0.0) & (geom.cross_norm > 0.0)
    safe = np.where(inside, den, 1.0)
    return np.where(inside, geom.axial / safe, np.inf)


def in_cone(geom: ConeGeometry, sigma: float) -> BoolArray:
    """Points strictly inside the cone (``Phi < 1`` below the apex), (N,) bool."""
    return phi(geom, sigma) < 1.0


def residual(geom: ConeGeometry, sigma: float) -> FloatArray:
    """``rho = (1 - Phi) Upsilon(x)`` inside the cone, 0 outside; (N,) float64, ``>= 0``."""
    ph = phi(geom, sigma)
    return np.where(ph < 1.0, (1.0 - np.minimum(ph, 1.0)) * upsilon(geom.height, sigma), 0.0)


def psi(geom: ConeGeometry, sigma: float) -> FloatArray:
    """Penalty ``Psi`` (Eq. 1), (N,) float64."""
    return residual(geom, sigma) ** 2


def _local_gradients(geom: ConeGeometry, sigma: float
                     ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """``rho`` and its gradients w.r.t. ``d`` (N, 3), ``n`` (N, 3) and ``r`` (N,)."""
    ph = phi(geom, sigma)
    inside = ph < 1.0
    x, s, r = geom.height, geom.axial, geom.radius
    den = np.where(inside, _denominator(geom, sigma), 1.0)
    ups = upsilon(x, sigma)
    ph_in = np.where(inside, ph, 0.0)
    rho = np.where(inside, (1.0 - ph_in) * ups, 0.0)
    d_s = np.where(inside, -ups / den, 0.0)
    d_x = np.where(inside, (1.0 - ph_in) * upsilon_derivative(x, sigma)
                   - ups * s * r / (sigma * den ** 2), 0.0)
    d_r = np.where(inside, ups * ph_in / r, 0.0)
    # On the axis (s = 0) the tangential direction is undefined: use the subgradient 0.
    inv_s = np.where(s > 0.0, 1.0 / np.where(s > 0.0, s, 1.0), 0.0)
    tangential = geom.offset - x[:, None] * geom.normal
    g_d = (d_s * inv_s)[:, None] * tangential + d_x[:, None] * geom.normal
    g_n = (d_x - d_s * x * inv_s)[:, None] * geom.offset
    return rho, g_d, g_n, d_r


def residual_and_gradients(points: FloatArray, triangles: FloatArray, sigma: float
                           ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Residual ``rho`` and its gradients w.r.t. the point and the receiver triangle.

    Parameters
    ----------
    points : (N, 3) float64
    triangles : (N, 3, 3) float64
    sigma : float
        Cone height, in the unit of ``points``.

    Returns
    -------
    rho : (N,) float64
    d_point : (N, 3) float64
        ``drho/dv``.
    d_triangle : (N, 3, 3) float64
        ``drho/dp_k`` for the triangle's vertex ``k`` (o, n and r all move with it).
    """
    geom = cone_geometry(points, triangles)
    rho, g_d, g_n, g_r = _local_gradients(geom, sigma)
    n = geom.normal
    safe_norm = np.where(geom.cross_norm > 0.0, geom.cross_norm, 1.0)
    g_m = (g_n - np.einsum('ij,ij->i', n, g_n)[:, None] * n) / safe_norm[:, None]
    e1 = triangles[:, 1] - triangles[:, 0]
    e2 = triangles[:, 2] - triangles[:, 0]
    d_tri = np.repeat((-g_d / 3.0)[:, None, :], 3, axis=1)
    g_p1 = np.cross(e2, g_m)
    g_p2 = np.cross(g_m, e1)
    d_tri[:, 0] -= g_p1 + g_p2
    d_tri[:, 1] += g_p1
    d_tri[:, 2] += g_p2
    rows = np.arange(len(points))
    spoke = triangles[rows, geom.active] - geom.origin
    u = spoke / geom.radius[:, None]
    g_u = g_r[:, None] * u
    d_tri -= g_u[:, None, :] / 3.0
    d_tri[rows, geom.active] += g_u
    return rho, g_d, d_tri
