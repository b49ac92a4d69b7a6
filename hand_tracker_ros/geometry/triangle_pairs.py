"""Intersecting triangles between non-adjacent parts of a mesh, and interpenetration depth.

**Pair search** (:func:`intersecting_pairs`), re-run on the deformed mesh every
correspondence round, in one numba kernel:

1. broad phase on parts: the axis-aligned box (AABB) of every part; only pairs of parts that
   are not adjacent and whose boxes overlap go on;
2. for such a pair, the triangles of each part whose AABB meets the intersection of the two
   part boxes; a sweep and prune over them along the longest axis of that box, keeping the
   pairs from different parts whose AABBs overlap on all three axes and that share no vertex;
3. the exact triangle-triangle test of Moeller (1997, "A fast triangle-triangle intersection
   test"): reject when one triangle lies strictly on one side of the other's plane, else
   compare the two intervals the planes cut on their line of intersection; coplanar
   triangles are tested in 2D (edge crossings, then containment). Triangles are closed sets:
   touching counts as intersecting. The plane-side tolerance is relative to the triangle size.

A bounding-volume hierarchy would have to be refitted every pose (measured, see
docs/references.md: fcl rebuilds cost 40-60 ms); the part boxes make a BVH's top levels for
free, and the sweep only sees the triangles in the overlap region: about 0.5-1.5 ms on the
9.8k-triangle hand (bench/bench_collision.py). No library offers a refit-free triangle-level
test, hence our own kernel.

**Interpenetration depth** (:func:`penetration_depths_m`, :func:`max_interpenetration_m`), the
evaluation metric: a vertex of part ``a`` penetrates part ``b`` (``a, b`` not adjacent) when its
generalized winding number (Jacobson et al. 2013) with respect to ``b``'s triangles exceeds
1/2::

    w(p) = 1 / (4 pi) sum_t Omega_t(p),
    tan(Omega_t / 2) = a . (b x c) / (|a||b||c| + (a.b)|c| + (a.c)|b| + (b.c)|a|)

(Van Oosterom and Strackee; ``a, b, c`` the corners of ``t`` relative to ``p``). The winding
number is the robust inside test for the open parts of a hand mesh (each part is a patch with
holes at its joints): it is ~1 inside a part, ~0 outside, and drops to ~1/2 only across its
openings, which border adjacent parts anyway. The depth is the distance from the vertex to the
triangles of ``b`` (trimesh closest point). A vertex shared by faces of several parts is tested
only against parts adjacent to none of them.
"""
from __future__ import annotations

import numba as nb
import numpy as np
import trimesh

from hand_tracker_ros._typing import BoolArray, FloatArray, Int32Array, IntArray
from hand_tracker_ros.checks import check_finite, check_shape
from hand_tracker_ros.errors import ShapeError

# Every kernel below is compiled with cache=True: compile once (about 20 s for all of them)
# and reuse the machine code from the on-disk cache in later processes; nogil=True lets the
# threads that share the live tracker's process run meanwhile.
# Plane-side tolerance relative to the longest edge of the two triangles.
_REL_EPS = 1e-10


@nb.njit(cache=True, nogil=True)
def _orient2(ax: float, ay: float, bx: float, by: float, cx: float, cy: float) -> float:
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@nb.njit(cache=True, nogil=True)
def _segments_cross_2d(p: np.ndarray, q: np.ndarray, r: np.ndarray, s: np.ndarray,
                       i0: int, i1: int) -> bool:
    """Closed segments ``pq`` and ``rs`` meet in the (i0, i1) projection."""
    o1 = _orient2(p[i0], p[i1], q[i0], q[i1], r[i0], r[i1])
    o2 = _orient2(p[i0], p[i1], q[i0], q[i1], s[i0], s[i1])
    o3 = _orient2(r[i0], r[i1], s[i0], s[i1], p[i0], p[i1])
    o4 = _orient2(r[i0], r[i1], s[i0], s[i1], q[i0], q[i1])
    if o1 * o2 > 0.0 or o3 * o4 > 0.0:
        return False
    if o1 == 0.0 and o2 == 0.0:  # collinear: overlap of the projections on both axes
        for i in (i0, i1):
            if max(p[i], q[i]) < min(r[i], s[i]) or max(r[i], s[i]) < min(p[i], q[i]):
                return False
    return True


@nb.njit(cache=True, nogil=True)
def _point_in_tri_2d(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray,
                     i0: int, i1: int) -> bool:
    d0 = _orient2(a[i0], a[i1], b[i0], b[i1], p[i0], p[i1])
    d1 = _orient2(b[i0], b[i1], c[i0], c[i1], p[i0], p[i1])
    d2 = _orient2(c[i0], c[i1], a[i0], a[i1], p[i0], p[i1])
    return (d0 >= 0.0 and d1 >= 0.0 and d2 >= 0.0) or (d0 <= 0.0 and d1 <= 0.0 and d2 <= 0.0)


@nb.njit(cache=True, nogil=True)
def _coplanar_intersect(v: np.ndarray, u: np.ndarray, normal: np.ndarray) -> bool:
    """Coplanar triangles ``v`` and ``u`` (3, 3): 2D test on the plane closest to theirs."""
    a = np.abs(normal)
    if a[0] >= a[1] and a[0] >= a[2]:
        i0, i1 = 1, 2
    elif a[1] >= a[2]:
        i0, i1 = 0, 2
    else:
        i0, i1 = 0, 1
    for i in range(3):
        for j in range(3):
            if _segments_cross_2d(v[i], v[(i + 1) % 3], u[j], u[(j + 1) % 3], i0, i1):
                return True
    return (_point_in_tri_2d(v[0], u[0], u[1], u[2], i0, i1)
            or _point_in_tri_2d(u[0], v[0], v[1], v[2], i0, i1))


@nb.njit(cache=True, nogil=True)
def _plane_distances(tri: np.ndarray, other: np.ndarray, eps: float
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Unit normal of ``tri`` and signed distances of ``other``'s vertices to its plane."""
    normal = np.cross(tri[1] - tri[0], tri[2] - tri[0])
    length = np.sqrt(np.sum(normal * normal))
    if length > 0.0:
        normal = normal / length
    dist = np.empty(3)
    for k in range(3):
        dist[k] = np.sum(normal * (other[k] - tri[0]))
        if abs(dist[k]) < eps:
            dist[k] = 0.0
    return normal, dist


@nb.njit(cache=True, nogil=True)
def _interval(proj: np.ndarray, dist: np.ndarray) -> tuple[float, float]:
    """Interval a triangle cuts on the planes' line (projections ``proj``, distances ``dist``).

    The vertex alone on its side of the other plane is ``k``; the crossing points of its two
    edges are ``proj[k] + (proj[j] - proj[k]) dist[k] / (dist[k] - dist[j])``.
    """
    if dist[0] * dist[1] > 0.0:
        k = 2
    elif dist[0] * dist[2] > 0.0:
        k = 1
    elif dist[1] * dist[2] > 0.0 or dist[0] != 0.0:
        k = 0
    elif dist[1] != 0.0:
        k = 1
    else:
        k = 2
    t = np.empty(2)
    n = 0
    for j in range(3):
        if j != k:
            den = dist[k] - dist[j]
            t[n] = proj[k] if den == 0.0 else proj[k] + (proj[j] - proj[k]) * dist[k] / den
            n += 1
    return min(t[0], t[1]), max(t[0], t[1])


@nb.njit(cache=True, nogil=True)
def _tri_tri_intersect(v: np.ndarray, u: np.ndarray) -> bool:
    """Moeller's interval test for closed triangles ``v`` and ``u`` (3, 3)."""
    scale = 0.0
    for k in range(3):
        for t in (v, u):
            e = t[(k + 1) % 3] - t[k]
            scale = max(scale, np.sqrt(np.sum(e * e)))
    eps = _REL_EPS * scale
    n1, du = _plane_distances(v, u, eps)
    if (du[0] > 0.0 and du[1] > 0.0 and du[2] > 0.0) or (
            du[0] < 0.0 and du[1] < 0.0 and du[2] < 0.0):
        return False
    n2, dv = _plane_distances(u, v, eps)
    if (dv[0] > 0.0 and dv[1] > 0.0 and dv[2] > 0.0) or (
            dv[0] < 0.0 and dv[1] < 0.0 and dv[2] < 0.0):
        return False
    if du[0] == 0.0 and du[1] == 0.0 and du[2] == 0.0:
        return _coplanar_intersect(v, u, n1)
    direction = np.cross(n1, n2)
    axis = np.argmax(np.abs(direction))
    lo1, hi1 = _interval(v[:, axis].copy(), dv)
    lo2, hi2 = _interval(u[:, axis].copy(), du)
    return not (hi1 < lo2 or hi2 < lo1)


@nb.njit(cache=True, nogil=True)
def _share_vertex(fa: np.ndarray, fb: np.ndarray) -> bool:
    for i in range(3):
        for j in range(3):
            if fa[i] == fb[j]:
                return True
    return False


@nb.njit(cache=True, nogil=True)
def _overlap(lo: np.ndarray, hi: np.ndarray, f: int, g: int) -> bool:
    for k in range(3):
        if lo[f, k] > hi[g, k] or lo[g, k] > hi[f, k]:
            return False
    return True


@nb.njit(cache=True, nogil=True)
def _in_box(lo: np.ndarray, hi: np.ndarray, f: int, blo: np.ndarray, bhi: np.ndarray) -> bool:
    for k in range(3):
        if lo[f, k] > bhi[k] or hi[f, k] < blo[k]:
            return False
    return True


@nb.njit(cache=True, nogil=True)
def _sweep_part_pair(verts: np.ndarray, faces: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                     ids: np.ndarray, side: np.ndarray, axis: int,
                     out: np.ndarray, n_out: int) -> tuple[np.ndarray, int]:
    """Sweep and prune the candidate faces ``ids`` of two parts (``side`` 0/1) along ``axis``."""
    order = np.argsort(lo[ids, axis])
    m = ids.size
    for i in range(m):
        f = ids[order[i]]
        for j in range(i + 1, m):
            g = ids[order[j]]
            if lo[g, axis] > hi[f, axis]:
                break
            if side[order[i]] == side[order[j]] or not _overlap(lo, hi, f, g):
                continue
            if _share_vertex(faces[f], faces[g]):
                continue
            if _tri_tri_intersect(verts[faces[f]], verts[faces[g]]):
                if n_out == out.shape[0]:
                    grown = np.empty((2 * out.shape[0], 2), np.int64)
                    grown[:n_out] = out
                    out = grown
                a, b = (f, g) if side[order[i]] == 0 else (g, f)
                out[n_out, 0] = a
                out[n_out, 1] = b
                n_out += 1
    return out, n_out


@nb.njit(cache=True, nogil=True)
def _pairs_kernel(verts: np.ndarray, faces: np.ndarray, order: np.ndarray, start: np.ndarray,
                  blocked: np.ndarray) -> np.ndarray:
    n_faces, n_parts = faces.shape[0], start.size - 1
    lo = np.empty((n_faces, 3))
    hi = np.empty((n_faces, 3))
    for f in range(n_faces):
        for k in range(3):
            c0, c1, c2 = verts[faces[f, 0], k], verts[faces[f, 1], k], verts[faces[f, 2], k]
            lo[f, k] = min(c0, c1, c2)
            hi[f, k] = max(c0, c1, c2)
    plo = np.full((n_parts, 3), np.inf)
    phi = np.full((n_parts, 3), -np.inf)
    # Scalar updates: np.minimum on rows allocates a temporary per face (4x the kernel).
    for p in range(n_parts):
        for f in order[start[p]:start[p + 1]]:
            for k in range(3):
                plo[p, k] = min(plo[p, k], lo[f, k])
                phi[p, k] = max(phi[p, k], hi[f, k])
    out = np.empty((64, 2), np.int64)
    n_out = 0
    for a in range(n_parts):
        for b in range(a + 1, n_parts):
            if blocked[a, b]:
                continue
            blo = np.maximum(plo[a], plo[b])
            bhi = np.minimum(phi[a], phi[b])
            if np.any(blo > bhi):
                continue
            ids = np.empty(start[a + 1] - start[a] + start[b + 1] - start[b], np.int64)
            side = np.empty(ids.size, np.int64)
            m = 0
            for s, p in ((0, a), (1, b)):
                for f in order[start[p]:start[p + 1]]:
                    if _in_box(lo, hi, f, blo, bhi):
                        ids[m] = f
                        side[m] = s
                        m += 1
            axis = int(np.argmax(bhi - blo))
            out, n_out = _sweep_part_pair(verts, faces, lo, hi, ids[:m], side[:m], axis,
                                          out, n_out)
    return out[:n_out].copy()


def triangles_intersect(tri_a: FloatArray, tri_b: FloatArray) -> bool:
    """Exact test for two closed triangles (3, 3) float64 (touching counts)."""
    check_shape('tri_a', tri_a, (3, 3))
    check_shape('tri_b', tri_b, (3, 3))
    return bool(_tri_tri_intersect(np.ascontiguousarray(tri_a, dtype=np.float64),
                                   np.ascontiguousarray(tri_b, dtype=np.float64)))


def face_parts(faces: Int32Array, vertex_part: Int32Array) -> Int32Array:
    """Part of each face (F,) int32: the part of at least two of its vertices, else vertex 0's."""
    vp = vertex_part[faces]
    return np.where(vp[:, 1] == vp[:, 2], vp[:, 1], vp[:, 0]).astype(np.int32)


def _check_mesh(vertices_m: FloatArray, faces: Int32Array | IntArray, face_part: Int32Array,
                adjacent_parts: BoolArray) -> None:
    check_shape('vertices_m', vertices_m, (None, 3))
    check_finite('vertices_m', vertices_m)
    check_shape('faces', faces, (None, 3))
    check_shape('face_part', face_part, (len(faces),))
    n_parts = len(adjacent_parts)
    check_shape('adjacent_parts', adjacent_parts, (n_parts, n_parts))
    if len(face_part) and (face_part.min() < 0 or face_part.max() >= n_parts):
        msg = f'`face_part` must index the {n_parts} parts of `adjacent_parts`'
        raise ShapeError(msg)


def _blocked(adjacent_parts: BoolArray) -> BoolArray:
    """Part pairs never tested: adjacent ones and the diagonal, made symmetric."""
    adj = np.asarray(adjacent_parts, dtype=bool)
    return adj | adj.T | np.eye(len(adj), dtype=bool)


def intersecting_pairs(vertices_m: FloatArray, faces: Int32Array | IntArray,
                       face_part: Int32Array, adjacent_parts: BoolArray) -> IntArray:
    """Intersecting triangle pairs between non-adjacent parts.

    Parameters
    ----------
    vertices_m : (V, 3) float64
        Deformed mesh.
    faces : (F, 3) int32 or int64
    face_part : (F,) int32
        Part of each face (see :func:`face_parts`), in ``[0, B)``.
    adjacent_parts : (B, B) bool
        Part pairs never reported (the diagonal is always excluded).

    Returns
    -------
    (K, 2) int64
        Face ids ``(f, g)`` with ``face_part[f] < face_part[g]``, in a deterministic order.
        Faces sharing a vertex are never reported.
    """
    _check_mesh(vertices_m, faces, face_part, adjacent_parts)
    order = np.argsort(face_part, kind='stable').astype(np.int64)
    start = np.searchsorted(face_part[order], np.arange(len(adjacent_parts) + 1))
    return _pairs_kernel(np.ascontiguousarray(vertices_m, dtype=np.float64),
                         np.ascontiguousarray(faces, dtype=np.int64), order,
                         start.astype(np.int64), _blocked(adjacent_parts))


@nb.njit(cache=True, nogil=True)
def _winding_kernel(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    # Scalar arithmetic on purpose: small temporary arrays would dominate the inner loop.
    out = np.zeros(points.shape[0])
    for i in range(points.shape[0]):
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        total = 0.0
        for t in range(triangles.shape[0]):
            ax, ay, az = triangles[t, 0, 0] - px, triangles[t, 0, 1] - py, triangles[t, 0, 2] - pz
            bx, by, bz = triangles[t, 1, 0] - px, triangles[t, 1, 1] - py, triangles[t, 1, 2] - pz
            cx, cy, cz = triangles[t, 2, 0] - px, triangles[t, 2, 1] - py, triangles[t, 2, 2] - pz
            la = np.sqrt(ax * ax + ay * ay + az * az)
            lb = np.sqrt(bx * bx + by * by + bz * bz)
            lc = np.sqrt(cx * cx + cy * cy + cz * cz)
            num = ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx)
            den = (la * lb * lc + (ax * bx + ay * by + az * bz) * lc
                   + (ax * cx + ay * cy + az * cz) * lb + (bx * cx + by * cy + bz * cz) * la)
            total += np.arctan2(num, den)
        out[i] = total / (2.0 * np.pi)
    return out


def winding_numbers(points: FloatArray, triangles: FloatArray) -> FloatArray:
    """Generalized winding numbers (N,) float64 of ``points`` (N, 3) w.r.t. ``triangles``.

    ``triangles`` (T, 3, 3) float64 oriented counter-clockwise seen from outside.
    """
    return _winding_kernel(np.ascontiguousarray(points, dtype=np.float64),
                           np.ascontiguousarray(triangles, dtype=np.float64))


def penetration_depths_m(vertices_m: FloatArray, faces: Int32Array, face_part: Int32Array,
                         adjacent_parts: BoolArray) -> FloatArray:
    """Per-vertex depth (V,) float64 inside non-adjacent parts (0 where none; see module doc)."""
    _check_mesh(vertices_m, faces, face_part, adjacent_parts)
    n_parts = len(adjacent_parts)
    member = np.zeros((len(vertices_m), n_parts), dtype=bool)
    member[faces.ravel(), np.repeat(face_part, 3)] = True
    excluded = (member.astype(np.int32) @ _blocked(adjacent_parts).astype(np.int32)) > 0
    depth = np.zeros(len(vertices_m))
    for b in range(n_parts):
        part_faces = faces[face_part == b]
        if not len(part_faces):
            continue
        corners = vertices_m[part_faces]
        lo, hi = corners.min(axis=(0, 1)), corners.max(axis=(0, 1))
        cand = np.flatnonzero(~excluded[:, b] & np.all((vertices_m >= lo) & (vertices_m <= hi),
                                                       axis=1))
        if not len(cand):
            continue
        inside = cand[winding_numbers(vertices_m[cand], corners) > 0.5]
        if not len(inside):
            continue
        mesh = trimesh.Trimesh(vertices_m, part_faces, process=False)
        _, dist, _ = trimesh.proximity.closest_point(mesh, vertices_m[inside])
        depth[inside] = np.maximum(depth[inside], dist)
    return depth


def max_interpenetration_m(vertices_m: FloatArray, faces: Int32Array, face_part: Int32Array,
                           adjacent_parts: BoolArray) -> float:
    """Maximum depth of a vertex inside a non-adjacent part (m), 0 when nothing penetrates.

    Parameters as in :func:`intersecting_pairs`; method in the module docstring.
    """
    depth = penetration_depths_m(vertices_m, faces, face_part, adjacent_parts)
    return float(depth.max(initial=0.0))
