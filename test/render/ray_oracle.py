"""Oracles of the renderer tests: random composite meshes and exact ray casting.

A module of its own (not conftest.py), so that ``from ray_oracle import ...`` cannot pick up
another directory's conftest module when several test directories are collected together.
"""
from __future__ import annotations

import numpy as np
import trimesh
from scipy.spatial.transform import Rotation

from hand_tracker_ros.geometry.camera import PinholeCamera


def random_parts_mesh(rng: np.random.Generator, n_capsules: int = 5,
                      n_spheres: int = 2) -> trimesh.Trimesh:
    """Capsules and spheres in random poses within ~6 cm of the origin (overlapping)."""
    parts = []
    for _ in range(n_capsules):
        part = trimesh.creation.capsule(height=rng.uniform(0.04, 0.08),
                                        radius=rng.uniform(0.008, 0.015), count=[16, 16])
        T = np.eye(4)
        T[:3, :3] = Rotation.random(random_state=rng).as_matrix()
        T[:3, 3] = rng.uniform(-0.03, 0.03, 3)
        parts.append(part.apply_transform(T))
    for _ in range(n_spheres):
        part = trimesh.creation.icosphere(subdivisions=2, radius=rng.uniform(0.01, 0.025))
        parts.append(part.apply_translation(rng.uniform(-0.04, 0.04, 3)))
    return trimesh.util.concatenate(parts)


def _triangle_boxes(camera: PinholeCamera, triangles: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Pixel boxes (lo, hi), each (F, 2) float64, that hold each triangle's image (NaN for a
    triangle behind the camera).

    The image of a triangle under the distorted projection has curved edges, so its box is
    taken from points sampled along the edges (and the vertices), grown by 1 px: conservative
    for the few-pixel triangles of these meshes, where the curvature across a triangle is far
    below a pixel.
    """
    weights = np.linspace(0.0, 1.0, 6)
    edges = [(1 - w) * triangles[:, i] + w * triangles[:, (i + 1) % 3]
             for i in range(3) for w in weights]
    uv, _ = camera.project(np.stack(edges, axis=1).reshape(-1, 3))
    uv = uv.reshape(len(triangles), len(edges), 2)
    return uv.min(axis=1) - 1.0, uv.max(axis=1) + 1.0       # NaN propagates


def _candidate_pairs(camera: PinholeCamera, triangles: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(triangle id, pixel column, pixel row) of every pixel in each triangle's box."""
    lo, hi = _triangle_boxes(camera, triangles)
    seen = np.all(np.isfinite(lo) & np.isfinite(hi), axis=1)
    lo = np.maximum(np.floor(np.nan_to_num(lo)), 0).astype(int)
    hi = np.minimum(np.ceil(np.nan_to_num(hi)), (camera.width - 1, camera.height - 1))
    size = np.where(seen[:, None], np.maximum(hi.astype(int) - lo + 1, 0), 0)
    count = size[:, 0] * size[:, 1]
    tri = np.repeat(np.arange(len(triangles)), count)
    k = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    dv, du = np.divmod(k, size[tri, 0])
    return tri, lo[tri, 0] + du, lo[tri, 1] + dv


def _ray_triangle_t(origin: np.ndarray, dirs: np.ndarray, triangles: np.ndarray
                    ) -> np.ndarray:
    """Ray parameter t of each (ray, triangle) pair, inf where it misses (Moeller-Trumbore,
    both sides):

        o + t d = (1 - a - b) p0 + a p1 + b p2,   a, b >= 0,  a + b <= 1,  t > 0,

    solved by Cramer's rule, ``[t, a, b] = [q.e2, s.p, d.q] / (e1.p)`` with ``e1 = p1 - p0``,
    ``e2 = p2 - p0``, ``s = o - p0``, ``p = d x e2``, ``q = s x e1``.

    origin : (3,) or (N, 3); dirs : (N, 3); triangles : (N, 3, 3). Returns (N,) float64.
    """
    p0, p1, p2 = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    e1, e2, s = p1 - p0, p2 - p0, origin - p0
    p = np.cross(dirs, e2)
    det = np.einsum('ij,ij->i', e1, p)
    ok = np.abs(det) > 1e-18
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    q = np.cross(s, e1)
    a = np.einsum('ij,ij->i', s, p) * inv
    b = np.einsum('ij,ij->i', dirs, q) * inv
    t = np.einsum('ij,ij->i', e2, q) * inv
    hit = ok & (a >= 0.0) & (b >= 0.0) & (a + b <= 1.0) & (t > 1e-9)
    return np.where(hit, t, np.inf)


def ray_cast(camera: PinholeCamera, mesh: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray]:
    """Oracle: (H, W) camera-z depth (inf where missed) and first-hit triangle id (-1).

    The ray through each pixel centre (``camera.rays``, undistorting) is intersected exactly
    with the triangles whose box holds the pixel (:func:`_ray_triangle_t`); the first hit is
    the smallest ``t``.
    """
    triangles = np.asarray(mesh.vertices, np.float64)[np.asarray(mesh.faces)]
    tri, cols, rows = _candidate_pairs(camera, triangles)
    origin, dirs = camera.rays(np.column_stack([cols, rows]).astype(np.float64))
    t = _ray_triangle_t(origin, dirs, triangles[tri])
    hit = np.isfinite(t)
    tri, cols, rows, t = tri[hit], cols[hit], rows[hit], t[hit]
    points = origin + t[:, None] * dirs[hit]
    z = points @ camera.R_cam_world[2] + camera.T_cam_world[2, 3]
    depth = np.full((camera.height, camera.width), np.inf)
    face = np.full((camera.height, camera.width), -1)
    pixel = rows * camera.width + cols
    order = np.lexsort((t, pixel))                   # by pixel, nearest first
    first = order[np.unique(pixel[order], return_index=True)[1]]
    depth[rows[first], cols[first]] = z[first]
    face[rows[first], cols[first]] = tri[first]
    return depth, face


def ray_cast_trimesh(camera: PinholeCamera, mesh: trimesh.Trimesh
                     ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`ray_cast` by trimesh's ray caster (slow; the check of the oracle itself)."""
    ys, xs = np.mgrid[0:camera.height, 0:camera.width]
    uv = np.column_stack([xs.ravel(), ys.ravel()]).astype(np.float64)
    origin, dirs = camera.rays(uv)
    locations, ray_ids, tri_ids = mesh.ray.intersects_location(
        np.broadcast_to(origin, dirs.shape), dirs, multiple_hits=False)
    depth = np.full((camera.height, camera.width), np.inf)
    face = np.full((camera.height, camera.width), -1)
    rows, cols = ys.ravel()[ray_ids], xs.ravel()[ray_ids]
    depth[rows, cols] = (locations @ camera.R_cam_world.T + camera.T_cam_world[:3, 3])[:, 2]
    face[rows, cols] = tri_ids
    return depth, face


def occlusion_by_rays(camera: PinholeCamera, vertices: np.ndarray,
                      mesh: trimesh.Trimesh) -> np.ndarray:
    """Oracle: (V,) how far (m) before each vertex the ray from the camera first hits, by the
    exact ray-triangle test of the triangles whose box holds the vertex's image."""
    triangles = np.asarray(mesh.vertices, np.float64)[np.asarray(mesh.faces)]
    lo, hi = _triangle_boxes(camera, triangles)
    uv, _ = camera.project(vertices)
    inside = np.all((uv[:, None] >= lo[None]) & (uv[:, None] <= hi[None]), axis=2)
    vertex, tri = np.nonzero(inside)
    origin = camera.center_world
    offsets = vertices - origin
    dist = np.linalg.norm(offsets, axis=1)
    dirs = offsets / dist[:, None]
    t = _ray_triangle_t(origin, dirs[vertex], triangles[tri])
    first = np.full(len(vertices), np.inf)
    np.minimum.at(first, vertex, t)                  # unit directions: t is the distance (m)
    return np.maximum(dist - first, 0.0)


def occlusion_by_rays_trimesh(camera: PinholeCamera, vertices: np.ndarray,
                              mesh: trimesh.Trimesh) -> np.ndarray:
    """:func:`occlusion_by_rays` by trimesh's ray caster (slow; the check of the oracle)."""
    origin = camera.center_world
    offsets = vertices - origin
    dist = np.linalg.norm(offsets, axis=1)
    dirs = offsets / dist[:, None]
    locations, ray_ids, _ = mesh.ray.intersects_location(
        np.broadcast_to(origin, dirs.shape), dirs, multiple_hits=False)
    first = np.full(len(vertices), np.inf)
    first[ray_ids] = np.linalg.norm(locations - origin, axis=1)
    return np.maximum(dist - first, 0.0)
