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

from dataclasses import dataclass

import numpy as np
import trimesh
from numpy.typing import ArrayLike

from hand_tracker_ros._typing import BoolArray, FloatArray, IntArray
from hand_tracker_ros.checks import check_shape
from hand_tracker_ros.config import param
from hand_tracker_ros.geometry.camera import PinholeCamera
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


def front_facing(camera: PinholeCamera, vertices_world: FloatArray,
                 faces: IntArray) -> BoolArray:
    """Whether each triangle faces the camera centre.

    Parameters
    ----------
    camera : PinholeCamera
    vertices_world : (V, 3) float64
    faces : (F, 3) int64
        Counter-clockwise seen from outside.

    Returns
    -------
    front : (F,) bool
    """
    v0, v1, v2 = (vertices_world[faces[:, k]] for k in range(3))
    normals = np.cross(v1 - v0, v2 - v0)
    return np.einsum('ij,ij->i', normals, camera.center_world - v0) > 0.0


def _edge_normals(uv: FloatArray, a: IntArray, b: IntArray, o: IntArray) -> FloatArray:
    """Unit perpendiculars of the image segments a-b pointing away from o; 0 if degenerate."""
    t = uv[b] - uv[a]
    n = np.column_stack([t[:, 1], -t[:, 0]])
    side = np.einsum('ij,ij->i', n, uv[o] - uv[a])
    n *= -np.sign(side)[:, None]
    length = np.linalg.norm(n, axis=1, keepdims=True)
    return np.divide(n, length, out=np.zeros_like(n), where=length > _MIN_LENGTH_PX)


def contour_points(camera: PinholeCamera, vertices_world: ArrayLike, edges: MeshEdges,
                   raster: RenderResult, config: ContourConfig = ContourConfig()
                   ) -> ContourPoints:
    """Visible contour-generator vertices with outward image normals and outer/inner labels.

    Parameters
    ----------
    camera : PinholeCamera
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
    verts = np.asarray(vertices_world, dtype=np.float64)
    check_shape('vertices_world', verts, (raster.uv_px.shape[0], 3))
    front = front_facing(camera, verts, edges.faces)
    side = front[edges.faces_of_edge]
    on_contour = side[:, 0] != side[:, 1]
    e_verts = edges.vertices[on_contour]
    # The opposite vertex of the front-facing one of the two triangles.
    opp = np.where(side[on_contour, 0], edges.opposite[on_contour, 0],
                   edges.opposite[on_contour, 1])
    uv = raster.uv_px
    n_edge = _edge_normals(uv, e_verts[:, 0], e_verts[:, 1], opp)
    # bincount is the fast scatter-add (np.add.at is ~10x slower).
    ends = e_verts.T.ravel()
    acc = np.column_stack([np.bincount(ends, np.tile(n_edge[:, k], 2), minlength=uv.shape[0])
                           for k in range(2)])
    ids = np.unique(e_verts)
    length = np.linalg.norm(acc[ids], axis=1)
    ids = ids[raster.visible_vertices[ids] & (length > _MIN_LENGTH_PX)]
    normals = acc[ids] / np.linalg.norm(acc[ids], axis=1, keepdims=True)
    return ContourPoints(vertex_ids=ids, uv_px=uv[ids], normals_px=normals,
                         is_outer=_outside_is_background(raster, uv[ids], normals,
                                                         config.outer_probe_px))


def _outside_is_background(raster: RenderResult, uv: FloatArray, normals: FloatArray,
                           probe_px: float) -> BoolArray:
    height, width = raster.mask.shape
    probe = np.rint(uv + probe_px * normals).astype(np.int64)
    inside = ((probe[:, 0] >= 0) & (probe[:, 0] < width)
              & (probe[:, 1] >= 0) & (probe[:, 1] < height))
    outer = np.ones(len(uv), dtype=bool)
    outer[inside] = ~raster.mask[probe[inside, 1], probe[inside, 0]]
    return outer


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
