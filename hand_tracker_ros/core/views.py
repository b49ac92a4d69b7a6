"""The model as each camera sees it: raster, visibility and contour points, once per round.

Edges, flow, salient points and the silhouette term all need the current model's per-camera
visibility and contours; they are computed here once per correspondence round and shared.
:func:`moved_views` carries views to a nearby pose without rendering again.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from hand_tracker_ros.geometry.camera_model import Camera
from hand_tracker_ros.model.hand import PosedHand
from hand_tracker_ros.render.contours import (
    ContourConfig,
    ContourPoints,
    MeshEdges,
    contour_points,
)
from hand_tracker_ros.render.rasterizer import RenderConfig, RenderResult, render


@dataclass(frozen=True, eq=False)
class ModelView:
    """The posed model in one camera."""

    camera: Camera
    raster: RenderResult
    contours: ContourPoints


# The terms read the mask, the depth and the vertex visibility, never the triangle ids.
_RENDER = RenderConfig(face_ids=False)


def model_views(posed: PosedHand, edges: MeshEdges, cameras: Sequence[Camera], *,
                render_config: RenderConfig = _RENDER,
                contour_config: ContourConfig = ContourConfig()) -> tuple[ModelView, ...]:
    """Render ``posed.vertices_m`` into every camera and extract its contour points.

    The triangles are ``edges.faces``, already int64 and contiguous: converting the model's
    int32 faces cost 0.14 of the 0.63 ms of a 320x240 render.
    """
    views = []
    for camera in cameras:
        raster = render(camera, posed.vertices_m, edges.faces, render_config)
        contours = contour_points(camera, posed.vertices_m, edges, raster, contour_config)
        views.append(ModelView(camera, raster, contours))
    return tuple(views)


def moved_views(views: Sequence[ModelView], posed: PosedHand) -> tuple[ModelView, ...]:
    """``views`` of a nearby pose carried to ``posed``: the vertex projections
    (``raster.uv_px``, ``raster.vertex_depth_m``, ``contours.uv_px``) are those of
    ``posed.vertices_m``; the mask, depth buffer, vertex visibility and the contour vertices
    with their normals stay those of the pose the views were rendered at.

    A fit of two or more rounds ends with these, carried from its last round's start (after
    an earlier round, the last moves the hand little: :func:`contour_shift_px` at most the
    tracker's ``carry_views_px``), instead of a fourth rendering: its fit took 0.93 of the
    time in lock-step A/Bs on held-out bags, with the same accuracy within their noise
    (README, "Fewer renderings a set").
    """
    out = []
    for view in views:
        uv, depth = view.camera.project(posed.vertices_m)
        uv.setflags(write=False)
        depth.setflags(write=False)
        raster = dataclasses.replace(view.raster, uv_px=uv, vertex_depth_m=depth)
        contours = dataclasses.replace(view.contours, uv_px=uv[view.contours.vertex_ids])
        out.append(ModelView(view.camera, raster, contours))
    return tuple(out)


def contour_shift_px(views: Sequence[ModelView], posed: PosedHand) -> float:
    """How far ``posed`` moves the contour points of ``views``, px: the median over a
    camera's contour vertices of ``|uv(posed) - contours.uv_px|``, the largest over the
    cameras (0 without contour points; NaN when a point went behind a camera). Only the
    contour vertices are projected, so the full projection (:func:`moved_views`) runs only
    for views that are carried."""
    shifts = []
    for view in views:
        ids = view.contours.vertex_ids
        if ids.size:
            uv, _ = view.camera.project(posed.vertices_m[ids])
            shifts.append(np.median(np.linalg.norm(uv - view.contours.uv_px, axis=1)))
    return float(np.max(shifts)) if shifts else 0.0
