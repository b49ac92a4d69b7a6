r"""Shaded skin-coloured RGB rendering of a mesh over a background image.

Per covered pixel, the rasterizer's triangle id gives the triangle; the pixel centre's
screen-space barycentric coordinates :math:`b_i` are made perspective-correct,
:math:`w_i = (b_i / z_i) / \sum_j (b_j / z_j)`, and interpolate the vertex normals and the
per-vertex albedo. The colour is Lambert plus ambient with one directional light fixed in
the camera frame:

.. math:: c = a \,(k_a + k_d \max(0, \hat n \cdot \hat l))

where :math:`a` is the skin colour times a per-vertex factor :math:`1 + \sigma \epsilon_v`,
:math:`\epsilon_v \sim N(0, 1)` drawn from ``seed`` (the same seed gives the same skin in
every frame). No shadows, no anti-aliasing.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from hand_tracker_ros._typing import FloatArray, UInt8Array
from hand_tracker_ros.checks import check_shape
from hand_tracker_ros.config import param
from hand_tracker_ros.errors import ImageFormatError
from hand_tracker_ros.geometry.camera_model import Camera
from hand_tracker_ros.render.rasterizer import RenderConfig, RenderResult, render


@dataclass(frozen=True)
class ShadingConfig:
    """Skin material and light."""

    skin_rgb: tuple[float, ...] = param((224.0, 172.0, 145.0), 'base skin colour (R, G, B)',
                                        low=0.0, high=255.0)
    albedo_sigma: float = param(0.06, 'relative per-vertex albedo variation (std)',
                                low=0.0, high=0.5)
    ambient: float = param(0.35, 'ambient light factor k_a', low=0.0, high=1.0)
    diffuse: float = param(0.65, 'diffuse light factor k_d', low=0.0, high=1.0)
    light_dir_cam: tuple[float, ...] = param(
        (0.3, -0.6, -1.0), 'direction towards the light in the camera frame (x right, y down)')


def vertex_albedo(n_vertices: int, seed: int, config: ShadingConfig) -> FloatArray:
    """Per-vertex RGB albedo (0-255 scale).

    Returns
    -------
    albedo : (V, 3) float64
        ``skin_rgb * (1 + albedo_sigma * eps_v)`` with a small per-channel variation
        (a third of the scalar one) so the skin is not a single hue.
    """
    rng = np.random.default_rng(seed)
    scalar = 1.0 + config.albedo_sigma * rng.standard_normal((n_vertices, 1))
    hue = 1.0 + config.albedo_sigma / 3.0 * rng.standard_normal((n_vertices, 3))
    return np.asarray(config.skin_rgb, dtype=np.float64) * scalar * hue


def _perspective_weights(raster: RenderResult, tri: np.ndarray, ys: np.ndarray,
                         xs: np.ndarray) -> FloatArray:
    """(P, 3) perspective-correct barycentric weights of pixel centres (``ys``, ``xs``) in
    their triangles ``tri`` (P, 3) of vertex ids."""
    uv = raster.uv_px[tri]
    (x0, y0), (x1, y1), (x2, y2) = uv[:, 0].T, uv[:, 1].T, uv[:, 2].T
    area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
    b0 = ((x2 - x1) * (ys - y1) - (y2 - y1) * (xs - x1)) / area
    b1 = ((x0 - x2) * (ys - y2) - (y0 - y2) * (xs - x2)) / area
    b = np.column_stack([b0, b1, 1.0 - b0 - b1]) / raster.vertex_depth_m[tri]
    return b / b.sum(axis=1, keepdims=True)


def render_rgb(camera: Camera, vertices_world: ArrayLike, faces: ArrayLike,
               vertex_normals: ArrayLike, background: UInt8Array, *, seed: int = 0,
               raster: RenderResult | None = None,
               config: ShadingConfig = ShadingConfig(),
               albedo_gain: ArrayLike | None = None) -> UInt8Array:
    """Shaded skin-coloured rendering of a mesh composited over ``background``.

    Parameters
    ----------
    camera : Camera
    vertices_world : (V, 3) float64
        Posed mesh vertices (m).
    faces : (F, 3) int
    vertex_normals : (V, 3) float64
        Outward unit vertex normals in the world frame.
    background : (H, W, 3) uint8
        RGB image of the camera's size (see :mod:`hand_tracker_ros.render.background`).
    seed : int
        Seed of the per-vertex albedo variation.
    raster : RenderResult, optional
        This view's rasterization if already computed (it is rendered otherwise).
    config : ShadingConfig
    albedo_gain : (V,) float64, optional
        Factor on each vertex's albedo (skin creases in the detector's training views).

    Returns
    -------
    image : (H, W, 3) uint8
        rgb8 image.

    Raises
    ------
    ValueError
        ``raster`` was rendered without triangle ids (``RenderConfig.face_ids``).
    """
    shape = (camera.height, camera.width, 3)
    if background.shape != shape or background.dtype != np.uint8:
        msg = f'`background` must be {shape} uint8, got {background.shape} {background.dtype}'
        raise ImageFormatError(msg)
    faces_arr = np.ascontiguousarray(faces, dtype=np.int64)
    normals = np.asarray(vertex_normals, dtype=np.float64)
    check_shape('vertex_normals', normals, (np.shape(vertices_world)[0], 3))
    if raster is None:
        raster = render(camera, vertices_world, faces_arr, RenderConfig(face_ids=True))
    if raster.face_id is None:
        msg = '`raster` has no triangle ids: render it with RenderConfig(face_ids=True)'
        raise ValueError(msg)
    ys, xs = np.nonzero(raster.mask)
    tri = faces_arr[raster.face_id[ys, xs]]
    w = _perspective_weights(raster, tri, ys, xs)
    n_cam = np.einsum('pk,pkj->pj', w, normals[tri]) @ camera.R_cam_world.T
    n_cam /= np.maximum(np.linalg.norm(n_cam, axis=1, keepdims=True), 1e-12)
    light = np.asarray(config.light_dir_cam, dtype=np.float64)
    light /= np.linalg.norm(light)
    shade = config.ambient + config.diffuse * np.clip(n_cam @ light, 0.0, None)
    albedo = vertex_albedo(len(normals), seed, config)
    if albedo_gain is not None:
        gain = np.asarray(albedo_gain, dtype=np.float64)
        check_shape('albedo_gain', gain, (len(normals),))
        albedo = albedo * gain[:, None]
    colour = np.einsum('pk,pkc->pc', w, albedo[tri]) * shade[:, None]
    image = background.copy()
    image[ys, xs] = np.clip(np.rint(colour), 0, 255).astype(np.uint8)
    return image
