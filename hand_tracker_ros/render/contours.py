r"""The model's contour edges in one view: outer silhouette and inner depth discontinuities.

Contour generator. A triangle is front-facing when its outward normal points towards the
camera centre c: :math:`n_f \cdot (c - x_{f,0}) > 0` (faces wound counter-clockwise seen
from outside, the trimesh convention). A mesh edge shared by a front-facing and a
back-facing triangle lies on the contour generator; its vertices that pass the renderer's
visibility test are the contour points.

Image normal. For a contour edge (a, b) with front-facing triangle (a, b, o), the surface
projects to the side of the image line through a and b where o lands, so the outward normal
is the unit perpendicular of :math:`u_b - u_a` pointing away from :math:`u_o`. A point's
normal is the normalised sum of the normals of its contour edges.

Outer vs inner. Probe the pixel ``outer_probe_px`` pixels outside the point along its
normal: background (or outside the image) means the outer silhouette boundary; another part
of the model there means an inner depth-discontinuity edge (the hand occludes itself).

Edge image. A model pixel is an edge pixel when one of its 4-neighbours is background or
more than ``depth_jump_m`` deeper, i.e. the near side of every silhouette and
depth-discontinuity boundary, as an edge detector would see it on a rendered image.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numba
import numpy as np
import trimesh
from numpy.typing import ArrayLike

from hand_tracker_ros._typing import BoolArray, FloatArray, IntArray
from hand_tracker_ros.checks import check_shape
from hand_tracker_ros.config import param
from hand_tracker_ros.geometry.camera_model import Camera
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.render.rasterizer import RenderResult

_MIN_LENGTH_PX = 1e-9


@dataclass(frozen=True)
class ContourConfig:
    """Contour extraction settings."""

    outer_probe_px: float = param(2.5, 'distance outside a contour point probed for background',
                                  unit='px', low=0.5, high=20.0)
    depth_jump_m: float = param(0.008, 'depth step between neighbour pixels that is an edge',
                                unit='m', low=0.0, high=1.0)


@dataclass(frozen=True, eq=False)
class MeshEdges:
    """Interior edges of a triangle mesh with their two triangles (fixed topology, build once).

    Attributes
    ----------
    faces : (F, 3) int64
        The mesh triangles.
    vertices : (E, 2) int64
        Vertex ids of each edge shared by two triangles.
    faces_of_edge : (E, 2) int64
        The two triangles sharing each edge.
    opposite : (E, 2) int64
        For each of the two triangles, its vertex not on the edge.
    """

    faces: IntArray
    vertices: IntArray
    faces_of_edge: IntArray
    opposite: IntArray

    @classmethod
    def from_faces(cls, faces: ArrayLike) -> MeshEdges:
        """Build the edge table with ``trimesh.graph.face_adjacency``.

        Parameters
        ----------
        faces : (F, 3) int
            Triangles of a (preferably watertight) mesh.
        """
        faces_arr = np.ascontiguousarray(faces, dtype=np.int64)
        check_shape('faces', faces_arr, (None, 3))
        adjacency, edges = trimesh.graph.face_adjacency(faces_arr, return_edges=True)
        adjacency = adjacency.astype(np.int64)
        edges = edges.astype(np.int64)
        # The third vertex of a triangle: its id sum minus the edge's two ids.
        sums = faces_arr.sum(axis=1)
        opposite = sums[adjacency] - edges.sum(axis=1, keepdims=True)
        for arr in (faces_arr, edges, adjacency, opposite):
            arr.setflags(write=False)
        return cls(faces_arr, edges, adjacency, opposite)


@functools.lru_cache(maxsize=8)
def model_edges(model: HandModel) -> MeshEdges:
    """The :class:`MeshEdges` of a hand model's mesh, built once per model: the tracker's, the
    calibration's, and the earlier one a result was posed with after the session rebuilt the
    model at another scale (``tracking/scale.py``)."""
    return MeshEdges.from_faces(model.faces)


@dataclass(frozen=True, eq=False)
class ContourPoints:
    """Visible contour-generator vertices of the model in one view.

    Attributes
    ----------
    vertex_ids : (N,) int64
        Mesh vertex ids, ascending.
    uv_px : (N, 2) float64
        Their distorted projections.
    normals_px : (N, 2) float64
        Unit image-plane normals of the contour, pointing away from the surface.
    is_outer : (N,) bool
        True on the outer silhouette (background just outside), False on inner
        depth-discontinuity edges (another part of the model just outside).
    """

    vertex_ids: IntArray
    uv_px: FloatArray
    normals_px: FloatArray
    is_outer: BoolArray


@numba.njit(cache=True, nogil=True)
def _front_facing(vertices: np.ndarray, faces: np.ndarray,
                  center: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    front = np.empty(faces.shape[0], dtype=np.bool_)
    for f in range(faces.shape[0]):
        i, j, k = faces[f, 0], faces[f, 1], faces[f, 2]
        a0, a1, a2 = (vertices[j, 0] - vertices[i, 0], vertices[j, 1] - vertices[i, 1],
                      vertices[j, 2] - vertices[i, 2])
        b0, b1, b2 = (vertices[k, 0] - vertices[i, 0], vertices[k, 1] - vertices[i, 1],
                      vertices[k, 2] - vertices[i, 2])
        n0, n1, n2 = a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0
        front[f] = (n0 * (center[0] - vertices[i, 0]) + n1 * (center[1] - vertices[i, 1])
                    + n2 * (center[2] - vertices[i, 2])) > 0.0
    return front


@numba.njit(cache=True, nogil=True)
def _contour_normals(uv: np.ndarray, front: np.ndarray, edge_vertices: np.ndarray,
                     faces_of_edge: np.ndarray, opposite: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover - compiled
    """Per-vertex sums (V, 2) of the unit image normals of its contour edges, and which
    vertices lie on a contour edge (V,) bool.

    numba because this runs per camera and round over every mesh edge (about 15k), where
    the numpy form (masking, fancy indexing, bincount, unique) cost 1-2 ms per camera. The
    sums are accumulated in the order the numpy form used (all first ends, then all second
    ends), so the results agree to the last bit.
    """
    n_v = uv.shape[0]
    acc = np.zeros((n_v, 2))
    on = np.zeros(n_v, dtype=np.bool_)
    n_e = edge_vertices.shape[0]
    normal = np.zeros((n_e, 2))
    # The contour edges in ascending order: the sums below visit only them (a few percent).
    contour = np.empty(n_e, dtype=np.int64)
    n_c = 0
    for e in range(n_e):
        f0 = front[faces_of_edge[e, 0]]
        if f0 == front[faces_of_edge[e, 1]]:
            continue
        contour[n_c] = e
        n_c += 1
        a, b = edge_vertices[e, 0], edge_vertices[e, 1]
        # The opposite vertex of the front-facing one of the two triangles.
        o = opposite[e, 0] if f0 else opposite[e, 1]
        n0, n1 = uv[b, 1] - uv[a, 1], -(uv[b, 0] - uv[a, 0])
        side = n0 * (uv[o, 0] - uv[a, 0]) + n1 * (uv[o, 1] - uv[a, 1])
        if side > 0.0:
            n0, n1 = -n0, -n1
        elif not side < 0.0:   # degenerate (0) or behind the camera (NaN)
            continue
        length = math.sqrt(n0 * n0 + n1 * n1)
        if length > _MIN_LENGTH_PX:
            normal[e, 0], normal[e, 1] = n0 / length, n1 / length
    for end in range(2):
        for e in contour[:n_c]:
            v = edge_vertices[e, end]
            on[v] = True
            acc[v, 0] += normal[e, 0]
            acc[v, 1] += normal[e, 1]
    return acc, on


def front_facing(camera: Camera, vertices_world: FloatArray,
                 faces: IntArray) -> BoolArray:
    """Whether each triangle faces the camera centre.

    Parameters
    ----------
    camera : Camera
    vertices_world : (V, 3) float64
    faces : (F, 3) int64
        Counter-clockwise seen from outside.

    Returns
    -------
    front : (F,) bool
    """
    return _front_facing(np.ascontiguousarray(vertices_world, dtype=np.float64),
                         np.ascontiguousarray(faces, dtype=np.int64), camera.center_world)


@numba.njit(cache=True, nogil=True)
def _contour_kernel(vertices: np.ndarray, faces: np.ndarray, center: np.ndarray,
                    uv: np.ndarray, visible: np.ndarray, mask: np.ndarray,
                    edge_vertices: np.ndarray, faces_of_edge: np.ndarray, opposite: np.ndarray,
                    probe_px: float
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover
    """:func:`contour_points` in one pass: ids (N,), normals (N, 2), outer (N,).

    numba because it runs per camera and round: the numpy selection and probing after the
    two kernels above cost as much as the kernels themselves (about 0.2 ms per camera). The
    arithmetic is that of the numpy form (``hypot``, division, ``rint``), so the results
    agree to the last bit.
    """
    front = _front_facing(vertices, faces, center)
    acc, on = _contour_normals(uv, front, edge_vertices, faces_of_edge, opposite)
    n_v = uv.shape[0]
    length = np.zeros(n_v)
    count = 0
    for v in range(n_v):
        if on[v] and visible[v]:
            length[v] = math.hypot(acc[v, 0], acc[v, 1])
            if length[v] > _MIN_LENGTH_PX:
                count += 1
    ids = np.empty(count, dtype=np.int64)
    normals = np.empty((count, 2))
    outer = np.ones(count, dtype=np.bool_)
    height, width = mask.shape
    k = 0
    for v in range(n_v):
        if not (on[v] and visible[v] and length[v] > _MIN_LENGTH_PX):
            continue
        ids[k] = v
        normals[k, 0] = acc[v, 0] / length[v]
        normals[k, 1] = acc[v, 1] / length[v]
        pu = np.rint(uv[v, 0] + probe_px * normals[k, 0])
        pv = np.rint(uv[v, 1] + probe_px * normals[k, 1])
        if 0 <= pu < width and 0 <= pv < height:
            outer[k] = not mask[int(pv), int(pu)]
        k += 1
    return ids, normals, outer


def contour_points(camera: Camera, vertices_world: ArrayLike, edges: MeshEdges,
                   raster: RenderResult, config: ContourConfig = ContourConfig()
                   ) -> ContourPoints:
    """Visible contour-generator vertices with outward image normals and outer/inner labels.

    Parameters
    ----------
    camera : Camera
        The view ``raster`` was rendered from.
    vertices_world : (V, 3) float64
        Posed mesh vertices (m), the ones given to :func:`render`.
    edges : MeshEdges
        Edge table of the mesh's faces.
    raster : RenderResult
        Output of :func:`hand_tracker_ros.render.rasterizer.render` for this view.
    config : ContourConfig

    Returns
    -------
    ContourPoints
        Empty arrays when the model has no visible contour in this view.
    """
    verts = np.ascontiguousarray(vertices_world, dtype=np.float64)
    check_shape('vertices_world', verts, (raster.uv_px.shape[0], 3))
    ids, normals, outer = _contour_kernel(
        verts, edges.faces, camera.center_world, raster.uv_px, raster.visible_vertices,
        raster.mask, edges.vertices, edges.faces_of_edge, edges.opposite,
        float(config.outer_probe_px))
    return ContourPoints(vertex_ids=ids, uv_px=raster.uv_px[ids], normals_px=normals,
                         is_outer=outer)


def edge_image(raster: RenderResult, config: ContourConfig = ContourConfig()) -> BoolArray:
    """Model edge pixels: silhouette boundary and depth discontinuities (near side).

    Parameters
    ----------
    raster : RenderResult
    config : ContourConfig
        ``depth_jump_m`` separates a depth discontinuity from a steep surface.

    Returns
    -------
    edges : (H, W) bool
    """
    depth = raster.depth_m
    # Pad with -inf so the image border itself never counts as a deeper neighbour.
    padded = np.pad(depth, 1, constant_values=-np.inf)
    deepest = np.maximum.reduce([padded[:-2, 1:-1], padded[2:, 1:-1],
                                 padded[1:-1, :-2], padded[1:-1, 2:]])
    return raster.mask & (deepest > depth + np.float32(config.depth_jump_m))
