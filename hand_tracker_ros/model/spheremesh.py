"""The sphere-mesh ("convolution surface") hand of Tkach, Pauly & Tagliasacchi 2016.

Spheres with per-sphere radii sit on the skeleton; the solid is the union of

- *pills*: the convex hull of two spheres (a round cone) along every finger bone, and
- *wedges*: the convex hull of three spheres spanning the palm.

The hull of balls ``B(c_i, r_i)`` is the union of the interpolated balls
``B(sum l_i c_i, sum l_i r_i)`` over barycentric ``l``, so a point's distance to an element
is ``min_u |x - c(u)| - r(u)`` outside it. For a pill it has the closed form of the round-cone
distance (Quilez, "distance functions", sdRoundCone). A wedge ``(A, B, C)`` is evaluated as
the union of the pills from ``A`` to ``_FAN`` points on ``BC``: every ball of the hull lies in
one of them up to a ridge of depth ``~ L dphi^2 / 8`` (< 0.05 mm for our palm).

Spheres: 0-1 wrist (radial, ulnar), 2-6 base joints (thumb CMC, index..pinky MCP), then per
finger i the spheres ``7 + 3 i + l`` at the distal end of segment ``l`` (the last one is the
tip sphere, tangent to the fingertip). A sphere belongs to the bone it is attached to.

References: docs/references.md.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hand_tracker_ros._typing import FloatArray, IntArray
from hand_tracker_ros.model.skeleton import RestSkeleton

_FAN = 16
# Palm wedges as sphere triples: heel to knuckles in a fan, plus the thenar web.
_WEDGES = np.array([[0, 3, 4], [0, 4, 1], [1, 4, 5], [1, 5, 6], [0, 2, 3]], dtype=np.int64)


@dataclass(frozen=True)
class SphereMesh:
    """Sphere-mesh elements of one hand shape.

    Attributes
    ----------
    sphere_bone : (S,) int64
        Bone each sphere is attached to.
    sphere_local_m : (S, 3) float64
        Sphere centres in their bone frames.
    centers_m : (S, 3) float64
        Sphere centres in the rest pose (hand frame).
    radii_m : (S,) float64
    pills : (Np, 2) int64
        Sphere pairs; ``pill_part`` (Np,) int64 the bone each pill belongs to.
    wedges : (Nw, 3) int64
        Sphere triples (all belong to the palm, bone 0).
    """

    sphere_bone: IntArray
    sphere_local_m: FloatArray
    centers_m: FloatArray
    radii_m: FloatArray
    pills: IntArray
    pill_part: IntArray
    wedges: IntArray


def build_sphere_mesh(rest: RestSkeleton, rest_transforms: FloatArray) -> SphereMesh:
    """Sphere mesh of ``rest``; ``rest_transforms`` (B, 4, 4) are the rest bone frames."""
    lengths, radii = rest.lengths_m, rest.finger_radii_m
    local = [*rest.wrist_m, *rest.base_m]
    bones = [0] * 7
    r = [*rest.wrist_radii_m, *radii[:, 0]]
    pills = []
    for i in range(5):
        for lvl in range(3):
            end = lengths[i, lvl] - (radii[i, 3] if lvl == 2 else 0.0)
            local.append(np.array([0.0, end, 0.0]))
            bones.append(1 + 3 * i + lvl)
            r.append(radii[i, lvl + 1])
            pills.append((2 + i if lvl == 0 else 6 + 3 * i + lvl, 7 + 3 * i + lvl))
    sphere_bone = np.asarray(bones, dtype=np.int64)
    local_m = np.asarray(local)
    t = rest_transforms[sphere_bone]
    centers = np.einsum('sij,sj->si', t[:, :3, :3], local_m) + t[:, :3, 3]
    pill_arr = np.asarray(pills, dtype=np.int64)
    return SphereMesh(sphere_bone=sphere_bone, sphere_local_m=local_m, centers_m=centers,
                      radii_m=np.asarray(r), pills=pill_arr,
                      pill_part=sphere_bone[pill_arr[:, 1]], wedges=_WEDGES.copy())


def round_cone_distance(points: FloatArray, a: FloatArray, b: FloatArray, ra: float,
                        rb: float) -> FloatArray:
    """Signed distance (N,) of points (N, 3) to the hull of spheres ``(a, ra)``, ``(b, rb)``.

    Exact outside; negative inside. Falls back to the larger sphere when one sphere
    contains the other (the hull is then that sphere).
    """
    ba = b - a
    l2 = float(ba @ ba)
    rr = ra - rb
    a2 = l2 - rr * rr
    if a2 <= 0.0:
        c, r = (a, ra) if ra >= rb else (b, rb)
        return np.linalg.norm(points - c, axis=1) - r
    pa = points - a
    y = pa @ ba
    z = y - l2
    x2 = np.sum((pa * l2 - y[:, None] * ba) ** 2, axis=1)
    y2, z2 = y * y * l2, z * z * l2
    k = np.sign(rr) * rr * rr * x2
    side = (np.sqrt(x2 * a2 / l2) + y * rr) / l2 - ra
    cap_a = np.sqrt(x2 + y2) / l2 - ra
    cap_b = np.sqrt(x2 + z2) / l2 - rb
    out = np.where(np.sign(y) * a2 * y2 < k, cap_a, side)
    return np.where(np.sign(z) * a2 * z2 > k, cap_b, out)


def element_pills(sm: SphereMesh) -> tuple[FloatArray, FloatArray, IntArray]:
    """Every element as round cones: ends (E, 2, 3), radii (E, 2) and part (E,) int64.

    Pills are one round cone each, wedges a fan of ``_FAN + 1`` round cones.
    """
    c, r = sm.centers_m, sm.radii_m
    ends, rads, parts = [c[sm.pills]], [r[sm.pills]], [sm.pill_part]
    t = np.linspace(0.0, 1.0, _FAN + 1)[:, None]
    for ia, ib, ic in sm.wedges:
        far = (1.0 - t) * c[ib] + t * c[ic]
        far_r = (1.0 - t[:, 0]) * r[ib] + t[:, 0] * r[ic]
        ends.append(np.stack([np.broadcast_to(c[ia], far.shape), far], axis=1))
        rads.append(np.column_stack([np.full(far_r.shape, r[ia]), far_r]))
        parts.append(np.zeros(far_r.shape, dtype=np.int64))
    return np.concatenate(ends), np.concatenate(rads), np.concatenate(parts)


def part_distances(points: FloatArray, sm: SphereMesh, n_parts: int) -> FloatArray:
    """Signed distance (N, n_parts) of points (N, 3) to the union of each part's elements."""
    ends, rads, parts = element_pills(sm)
    dist = np.full((points.shape[0], n_parts), np.inf)
    for (a, b), (ra, rb), part in zip(ends, rads, parts):
        dist[:, part] = np.minimum(dist[:, part], round_cone_distance(points, a, b, ra, rb))
    return dist
