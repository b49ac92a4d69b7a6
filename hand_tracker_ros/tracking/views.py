"""The model as each camera sees it: raster, visibility and contour points, once per round.

Edges, flow, salient points and the silhouette term all need the current model's per-camera
visibility and contours; they are computed here once per correspondence round and shared.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from hand_tracker_ros.energies.collision import CollisionPairs
from hand_tracker_ros.geometry.camera import PinholeCamera
from hand_tracker_ros.render.contours import ContourConfig, ContourPoints, MeshEdges, contour_points
from hand_tracker_ros.render.rasterizer import RenderConfig, RenderResult, render
from hand_tracker_ros.tracking.observations import FrameObservations


@dataclass(frozen=True, eq=False)
class ModelView:
    """The posed model in one camera."""

    camera: PinholeCamera
    raster: RenderResult
    contours: ContourPoints


def model_views(posed: Any, faces: Any, edges: MeshEdges,
                cameras: Sequence[PinholeCamera], *,
                render_config: RenderConfig = RenderConfig(),
                contour_config: ContourConfig = ContourConfig()) -> tuple[ModelView, ...]:
    """Render ``posed.vertices_m`` into every camera and extract its contour points."""
    views = []
    for camera in cameras:
        raster = render(camera, posed.vertices_m, faces, render_config)
        contours = contour_points(camera, posed.vertices_m, edges, raster, contour_config)
        views.append(ModelView(camera, raster, contours))
    return tuple(views)


@dataclass(frozen=True, eq=False)
class PreviousFrame:
    """The estimate of the previous frame(s), for the flow and temporal terms.

    Attributes
    ----------
    posed : PosedHand
        The model posed at the previous frame's estimate (``theta[t-1]``).
    views : tuple of ModelView
        Its per-camera views (visibility at t-1 decides which points flow may carry).
    thetas : (K, P) float64
        The last K estimates, oldest first (K >= 1; the temporal prior uses up to 2).
    """

    posed: Any
    views: tuple[ModelView, ...]
    thetas: Any


@dataclass(frozen=True, eq=False)
class RoundContext:
    """Everything ``Energy.correspond`` may use for one correspondence round.

    ``collisions`` holds the cone-field constraints of the frame's earlier rounds, which the
    collision term keeps (a round's LM steps could otherwise slide a finger back into a
    contact an earlier round resolved, unseen until the next round).
    """

    posed: Any
    views: tuple[ModelView, ...]
    observations: FrameObservations
    previous: PreviousFrame | None
    collisions: CollisionPairs | None = None
