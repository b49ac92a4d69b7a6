r"""Z-buffer rasterizer: depth, silhouette mask, per-pixel triangle id and vertex visibility.

Vertices are projected with the camera's full distortion model, then each triangle is
rasterized as a straight-edged 2D triangle in the distorted image (its edges are slightly
curved in reality; for the hand's ~4 mm triangles the difference is far below a pixel).

Pixel convention (the same as :meth:`PinholeCamera.project`): the centre of pixel (u, v)
is at integer coordinates and the pixel covers [u - 0.5, u + 0.5) x [v - 0.5, v + 0.5).
A pixel belongs to a triangle when its centre lies inside or on the triangle's edges
(barycentric coordinates >= -1e-9, absorbing rounding), so triangles sharing an edge
leave no gaps. With screen-space barycentric coordinates
:math:`b_i` of the pixel centre, depth is interpolated perspective-correctly (1/z is affine
in the image of a plane):

.. math:: z = 1 / (b_0 / z_0 + b_1 / z_1 + b_2 / z_2)

and the nearest triangle wins. Triangles with any vertex at depth <= ``near_m`` are skipped
(no near-plane clipping: the hand never straddles a camera).

Back-face culling (``cull_back_faces``, default on) halves the work. A triangle wound
counter-clockwise seen from outside (the trimesh convention) faces the camera iff its
image-space signed area :math:`(u_1 - u_0) \times (u_2 - u_0)` is negative (the image y axis
points down). For a closed, consistently wound mesh the culled triangles are always hidden,
so the result is unchanged; turn culling off for open meshes or unknown winding, and the
result equals ray casting through the pixel centres for any mesh.

Vertex visibility (definition): vertex i is visible iff its depth z_i > ``near_m``, its
projection rounds to a pixel (u, v) inside the image, and at least one pixel of the 3 x 3
neighbourhood of (u, v) (clipped to the image) has z-buffer depth >= z_i - ``visibility_tol_m``
(background counts as infinitely deep). The neighbourhood keeps vertices that lie exactly
on the silhouette, whose own pixel may show background or a neighbouring face.

Triangle ids (``face_ids``, default on) cost a second full-image buffer and a write per
covered pixel. The tracker reads only the mask, the depth and the vertex visibility, and
without the ids its fit took 0.975 of the time (lock-step A/B on held-out bags, the same
estimates), so :func:`hand_tracker_ros.core.views.model_views` turns them off; shading needs
them. The mask is the z-buffer's finite pixels either way (a covered pixel always has a
finite depth).

The kernels are numba ``@njit(cache=True, nogil=True)``: a compiled z-buffer is 10-40x faster
than numpy/OpenCV/embree alternatives (bench/bench_render.py: 0.07-0.12 ms per 320x240
view); ``cache=True`` stores the machine code on disk so the ~1 s compile is paid once, not
by every process; ``nogil`` lets callers render cameras from several threads.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import ArrayLike

from hand_tracker_ros._typing import BoolArray, Float32Array, FloatArray, Int32Array, IntArray
from hand_tracker_ros.checks import check_shape
from hand_tracker_ros.config import param
from hand_tracker_ros.errors import ShapeError
from hand_tracker_ros.geometry.camera_model import Camera

# Barycentric slack so pixel centres exactly on an edge stay inside despite rounding.
_INSIDE_EPS = 1e-9


@dataclass(frozen=True)
class RenderConfig:
    """Rasterizer settings."""

    near_m: float = param(0.01, 'triangles with a vertex closer than this are skipped',
                          unit='m', low=1e-6, high=1.0)
    visibility_tol_m: float = param(0.002, 'depth slack of the vertex visibility test',
                                    unit='m', low=0.0, high=0.05)
    cull_back_faces: bool = param(True, 'skip triangles facing away (closed, outward-wound '
                                  'meshes only)')
    face_ids: bool = param(True, 'also keep the nearest triangle of every pixel (shading '
                           'needs it; the tracker does not)')


@dataclass(frozen=True, eq=False)
class RenderResult:
    """One camera's rendering of a triangle mesh.

    Attributes
    ----------
    depth_m : (H, W) float32
        Camera-frame z of the nearest surface at each pixel centre; ``np.inf`` where empty.
    mask : (H, W) bool
        Silhouette: True where a triangle covers the pixel centre.
    face_id : (H, W) int32 or None
        Index of the nearest triangle, -1 where empty; None unless ``RenderConfig.face_ids``.
    visible_vertices : (V,) bool
        Vertex visibility as defined in the module docstring.
    uv_px : (V, 2) float64
        Distorted projections of the vertices (NaN behind the camera).
    vertex_depth_m : (V,) float64
        Camera-frame z of the vertices.
    """

    depth_m: Float32Array
    mask: BoolArray
    face_id: Int32Array | None
    visible_vertices: BoolArray
    uv_px: FloatArray
    vertex_depth_m: FloatArray


@numba.njit(cache=True, nogil=True)
def _rasterize(uv: FloatArray, z: FloatArray, faces: np.ndarray, width: int, height: int,
               near: float, cull: bool, face_ids: bool) -> tuple[Float32Array, Int32Array]:
    zbuf = np.full((height, width), np.inf, dtype=np.float32)
    fbuf = np.full((height if face_ids else 0, width if face_ids else 0), -1, dtype=np.int32)
    for f in range(faces.shape[0]):
        i0, i1, i2 = faces[f, 0], faces[f, 1], faces[f, 2]
        if z[i0] <= near or z[i1] <= near or z[i2] <= near:
            continue
        x0, y0, x1, y1, x2, y2 = uv[i0, 0], uv[i0, 1], uv[i1, 0], uv[i1, 1], uv[i2, 0], uv[i2, 1]
        area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
        if area == 0.0 or (cull and area > 0.0):
            continue
        xmin = max(math.ceil(min(x0, x1, x2)), 0)
        xmax = min(math.floor(max(x0, x1, x2)), width - 1)
        ymin = max(math.ceil(min(y0, y1, y2)), 0)
        ymax = min(math.floor(max(y0, y1, y2)), height - 1)
        inv_area = 1.0 / area
        iz0, iz1, iz2 = 1.0 / z[i0], 1.0 / z[i1], 1.0 / z[i2]
        for py in range(ymin, ymax + 1):
            for px in range(xmin, xmax + 1):
                b0 = ((x2 - x1) * (py - y1) - (y2 - y1) * (px - x1)) * inv_area
                b1 = ((x0 - x2) * (py - y2) - (y0 - y2) * (px - x2)) * inv_area
                b2 = 1.0 - b0 - b1
                if b0 < -_INSIDE_EPS or b1 < -_INSIDE_EPS or b2 < -_INSIDE_EPS:
                    continue
                depth = np.float32(1.0 / (b0 * iz0 + b1 * iz1 + b2 * iz2))
                if depth < zbuf[py, px]:
                    zbuf[py, px] = depth
                    if face_ids:
                        fbuf[py, px] = f
    return zbuf, fbuf


@numba.njit(cache=True, nogil=True)
def _visible(uv: FloatArray, z: FloatArray, zbuf: Float32Array, near: float,
             tol: FloatArray) -> BoolArray:
    height, width = zbuf.shape
    out = np.zeros(z.shape[0], dtype=np.bool_)
    for i in range(z.shape[0]):
        if z[i] <= near:
            continue
        cu = round(uv[i, 0])
        cv = round(uv[i, 1])
        if cu < 0 or cu >= width or cv < 0 or cv >= height:
            continue
        for py in range(max(cv - 1, 0), min(cv + 2, height)):
            for px in range(max(cu - 1, 0), min(cu + 2, width)):
                if zbuf[py, px] >= z[i] - tol[i]:
                    out[i] = True
                    break
            if out[i]:
                break
    return out


def visible_with_slack(raster: RenderResult, vertex_ids: IntArray, slack_m: FloatArray,
                       near_m: float = RenderConfig().near_m) -> BoolArray:
    """The vertex visibility test (module docstring) of ``vertex_ids`` (K,) with a depth slack
    of its own for each, ``slack_m`` (K,) in m, in place of ``visibility_tol_m``: (K,) bool."""
    ids = np.asarray(vertex_ids, dtype=np.int64)
    slack = np.asarray(slack_m, dtype=np.float64)
    check_shape('slack_m', slack, ids.shape)
    return _visible(raster.uv_px[ids], raster.vertex_depth_m[ids], raster.depth_m, near_m, slack)


def render(camera: Camera, vertices_world: ArrayLike, faces: ArrayLike,
           config: RenderConfig = RenderConfig()) -> RenderResult:
    """Rasterize a triangle mesh into one camera.

    Parameters
    ----------
    camera : Camera
        The view (with distortion).
    vertices_world : (V, 3) float64
        Mesh vertices in the world frame (m).
    faces : (F, 3) int
        Vertex indices of each triangle.
    config : RenderConfig
        Near plane, visibility tolerance, back-face culling and whether to keep triangle ids.

    Returns
    -------
    RenderResult
        Depth, mask, triangle ids (``config.face_ids``), vertex visibility and the vertex
        projections.
    """
    faces_arr = np.ascontiguousarray(faces, dtype=np.int64)
    check_shape('faces', faces_arr, (None, 3))
    n_vertices = np.shape(vertices_world)[0] if np.ndim(vertices_world) == 2 else 0
    if faces_arr.size and (faces_arr.min() < 0 or faces_arr.max() >= n_vertices):
        msg = f'`faces` index out of range for {n_vertices} vertices'
        raise ShapeError(msg)
    uv, z = camera.project(vertices_world)
    zbuf, fbuf = _rasterize(uv, z, faces_arr, camera.width, camera.height, config.near_m,
                            config.cull_back_faces, config.face_ids)
    visible = _visible(uv, z, zbuf, config.near_m, np.full(z.shape[0], config.visibility_tol_m))
    for arr in (uv, z, visible):
        arr.setflags(write=False)
    return RenderResult(depth_m=zbuf, mask=zbuf < np.inf,
                        face_id=fbuf if config.face_ids else None,
                        visible_vertices=visible, uv_px=uv, vertex_depth_m=z)
