"""Watertight skinned triangle mesh of the sphere-mesh hand (rest pose).

Construction (deterministic, ~0.15 s, cached per shape by :mod:`.hand`):

1. Sample the signed distance of the sphere-mesh (:mod:`.spheremesh`) on a regular grid of
   spacing ``h`` around the rest hand. Each round cone is evaluated only inside its bounding
   box grown by ``3 h``; elsewhere the field keeps the value ``3 h``. Every grid point within
   ``h`` of the surface lies in the box of the element nearest to it, so the sign changes and
   the interpolation that marching cubes uses are exact.
2. Marching cubes (scikit-image, Lewiner's topology-consistent variant) on the padded grid:
   a closed, consistently oriented surface.
3. A few Taubin smoothing passes (trimesh) remove the grid stair-steps without shrinking the
   volume or changing connectivity, so the mesh stays watertight.

Skinning weights. For every vertex, ``d_b`` is its signed distance to the elements of part
(bone) ``b``. The dominant part minimises ``d_b``; the dominant part, its parent and its
children get ``w_b = (1 - (d_b - d_min) / blend)_+^2``, normalised, keeping the 4 largest.
Near a joint two pills meet and both distances are close, so the weights blend smoothly
across the joint over about ``blend`` (6 mm at scale 1); elsewhere the vertex is rigid.

Fingertip vertices: for each finger, among vertices whose dominant part is the distal bone,
the one farthest along the distal bone's axis (+y) from its joint.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh
from skimage.measure import marching_cubes

from hand_tracker_ros._typing import BoolArray, FloatArray, Int32Array, IntArray
from hand_tracker_ros.model.skeleton import BONE_PARENTS, B
from hand_tracker_ros.model.spheremesh import (
    SphereMesh,
    element_pills,
    part_distances,
    round_cone_distance,
)

MAX_INFLUENCES = 4
_GRID_SPACING_M = 0.0033
_BLEND_M = 0.006
_TAUBIN_ITERATIONS = 10


@dataclass(frozen=True)
class SkinnedMesh:
    """Rest-pose mesh with skinning data.

    Attributes
    ----------
    vertices_m : (V, 3) float64
        Rest vertices in the hand frame.
    faces : (F, 3) int32
        Outward-oriented triangles.
    weights : (V, B) float64
        Skinning weights, rows sum to 1.
    influence_bones : (V, MAX_INFLUENCES) int64
        Bones with non-zero weight (padded with the dominant bone and weight 0).
    influence_weights : (V, MAX_INFLUENCES) float64
    vertex_part : (V,) int32
        Dominant bone.
    fingertip_vertex_ids : (5,) int64
    """

    vertices_m: FloatArray
    faces: Int32Array
    weights: FloatArray
    influence_bones: IntArray
    influence_weights: FloatArray
    vertex_part: Int32Array
    fingertip_vertex_ids: IntArray


def _sdf_grid(sm: SphereMesh, spacing: float) -> tuple[FloatArray, FloatArray]:
    """Distance field (nx, ny, nz) and the grid origin (3,)."""
    margin = 3.0 * spacing
    lo = (sm.centers_m - sm.radii_m[:, None]).min(axis=0) - 2.0 * margin
    hi = (sm.centers_m + sm.radii_m[:, None]).max(axis=0) + 2.0 * margin
    shape = np.ceil((hi - lo) / spacing).astype(int) + 1
    field = np.full(shape, margin)
    ends, rads, _ = element_pills(sm)
    for (a, b), (ra, rb) in zip(ends, rads):
        box_lo = np.minimum(a - ra, b - rb) - margin
        box_hi = np.maximum(a + ra, b + rb) + margin
        i0 = np.floor((box_lo - lo) / spacing).astype(int)
        i1 = np.ceil((box_hi - lo) / spacing).astype(int) + 1
        axes = [lo[d] + spacing * np.arange(i0[d], i1[d]) for d in range(3)]
        pts = np.stack(np.meshgrid(*axes, indexing='ij'), axis=-1).reshape(-1, 3)
        sub = round_cone_distance(pts, a, b, ra, rb).reshape(i1 - i0)
        view = field[i0[0]:i1[0], i0[1]:i1[1], i0[2]:i1[2]]
        np.minimum(view, sub, out=view)
    return field, lo


def build_surface(sm: SphereMesh, scale: float) -> trimesh.Trimesh:
    """Watertight, smoothed surface of the sphere mesh (rest pose, hand frame)."""
    spacing = _GRID_SPACING_M * scale
    field, origin = _sdf_grid(sm, spacing)
    verts, faces, _, _ = marching_cubes(field, level=0.0, spacing=(spacing,) * 3)
    mesh = trimesh.Trimesh(verts + origin, faces, process=True)
    if mesh.volume < 0.0:
        # Our field is negative inside; flip if the extractor wound the faces inwards.
        mesh.invert()
    trimesh.smoothing.filter_taubin(mesh, iterations=_TAUBIN_ITERATIONS)
    return mesh


def _children() -> list[list[int]]:
    kids: list[list[int]] = [[] for _ in range(B)]
    for b, p in enumerate(BONE_PARENTS):
        if p >= 0:
            kids[p].append(b)
    return kids


def skin_weights(verts: FloatArray, sm: SphereMesh, scale: float) -> FloatArray:
    """Skinning weights (V, B) float64 of rest vertices (V, 3); see the module docstring."""
    dist = part_distances(verts, sm, B)
    dominant = np.argmin(dist, axis=1)
    allowed = np.eye(B, dtype=bool)
    for b, kids in enumerate(_children()):
        allowed[b, kids] = True
        if BONE_PARENTS[b] >= 0:
            allowed[b, BONE_PARENTS[b]] = True
    excess = (dist - dist[np.arange(len(verts)), dominant][:, None]) / (_BLEND_M * scale)
    w = np.clip(1.0 - excess, 0.0, None) ** 2 * allowed[dominant]
    # Keep the MAX_INFLUENCES largest weights per vertex.
    cut = -np.sort(-w, axis=1)[:, MAX_INFLUENCES - 1:MAX_INFLUENCES]
    w[w < cut] = 0.0
    return w / w.sum(axis=1, keepdims=True)


def influences(weights: FloatArray) -> tuple[IntArray, FloatArray]:
    """Sparse form of weights (V, B): bones and weights (V, MAX_INFLUENCES), largest first."""
    order = np.argsort(-weights, axis=1, kind='stable')[:, :MAX_INFLUENCES]
    return order.astype(np.int64), np.take_along_axis(weights, order, axis=1)


def fingertip_vertices(verts: FloatArray, part: Int32Array,
                       rest_transforms: FloatArray) -> IntArray:
    """Per finger, the distal-bone vertex farthest along the distal bone axis: (5,) int64."""
    ids = np.zeros(5, dtype=np.int64)
    for i in range(5):
        bone = 1 + 3 * i + 2
        t = rest_transforms[bone]
        reach = (verts - t[:3, 3]) @ t[:3, 1]
        reach[part != bone] = -np.inf
        ids[i] = int(np.argmax(reach))
    return ids


def adjacent_parts() -> BoolArray:
    """Part pairs (B, B) bool the collision term ignores.

    True on the diagonal, for parent/child pairs, and for the first segments of neighbouring
    fingers (thumb-index, index-middle, middle-ring, ring-pinky), which share the skin web
    between the knuckles in the mesh.
    """
    adj = np.eye(B, dtype=bool)
    for b, p in enumerate(BONE_PARENTS):
        if p >= 0:
            adj[b, p] = adj[p, b] = True
    for i in range(4):
        a, b = 1 + 3 * i, 1 + 3 * (i + 1)
        adj[a, b] = adj[b, a] = True
    return adj


def build_skinned_mesh(sm: SphereMesh, rest_transforms: FloatArray,
                       scale: float) -> SkinnedMesh:
    """Mesh, weights and fingertip ids of the sphere mesh ``sm`` at shape ``scale``."""
    surface = build_surface(sm, scale)
    verts = np.ascontiguousarray(surface.vertices, dtype=np.float64)
    weights = skin_weights(verts, sm, scale)
    bones, w = influences(weights)
    part = bones[:, 0].astype(np.int32)
    return SkinnedMesh(vertices_m=verts, faces=np.asarray(surface.faces, dtype=np.int32),
                       weights=weights, influence_bones=bones, influence_weights=w,
                       vertex_part=part,
                       fingertip_vertex_ids=fingertip_vertices(verts, part, rest_transforms))
