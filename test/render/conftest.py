"""Fixtures of the renderer tests: random composite meshes and a trimesh ray-casting oracle."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from hand_tracker_ros.geometry.camera import PinholeCamera


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(1234)


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


def ray_cast(camera: PinholeCamera, mesh: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray]:
    """Oracle: (H, W) camera-z depth (inf where missed) and first-hit triangle id (-1).

    Only pixels inside the bounding box of the projected vertices (+2 px) are cast (rtree
    ray casting is slow); a ray outside the projected convex hull cannot hit the mesh.
    """
    uv_v, _ = camera.project(mesh.vertices)
    lo = np.maximum(np.floor(uv_v.min(axis=0)) - 2, 0).astype(int)
    hi = np.minimum(np.ceil(uv_v.max(axis=0)) + 2, (camera.width - 1, camera.height - 1))
    ys, xs = np.mgrid[lo[1]:int(hi[1]) + 1, lo[0]:int(hi[0]) + 1]
    uv = np.column_stack([xs.ravel(), ys.ravel()]).astype(np.float64)
    origin, dirs = camera.rays(uv)
    origins = np.broadcast_to(origin, dirs.shape)
    locations, ray_ids, tri_ids = mesh.ray.intersects_location(origins, dirs,
                                                               multiple_hits=False)
    depth = np.full((camera.height, camera.width), np.inf)
    face = np.full((camera.height, camera.width), -1)
    rows, cols = ys.ravel()[ray_ids], xs.ravel()[ray_ids]
    depth[rows, cols] = (locations @ camera.R_cam_world.T + camera.T_cam_world[:3, 3])[:, 2]
    face[rows, cols] = tri_ids
    return depth, face


def occlusion_by_rays(camera: PinholeCamera, vertices: np.ndarray,
                      mesh: trimesh.Trimesh) -> np.ndarray:
    """Oracle: (V,) how far (m) before each vertex the ray from the camera first hits."""
    origin = camera.center_world
    offsets = vertices - origin
    dist = np.linalg.norm(offsets, axis=1)
    dirs = offsets / dist[:, None]
    locations, ray_ids, _ = mesh.ray.intersects_location(
        np.broadcast_to(origin, dirs.shape), dirs, multiple_hits=False)
    first = np.full(len(vertices), np.inf)
    first[ray_ids] = np.linalg.norm(locations - origin, axis=1)
    return np.maximum(dist - first, 0.0)
