"""The camera seam: what the core needs from a calibrated camera, whatever its lens model.

Rendering, the energies, tracking and evaluation type their cameras as :class:`Camera`;
:class:`~hand_tracker_ros.geometry.camera.PinholeCamera` (pinhole with OpenCV distortion) is
the first implementation. Another model (a fisheye, say) implements the same members; the
calibration I/O (``geometry/rig.py``, CameraInfo) and the fused numba kernel of the image
terms (``energies/_projection.py``, which falls back to :meth:`Camera.project_jacobian` for
any other model) are the pinhole-specific places.

Conventions: world points in m, ``p_cam = T_cam_world @ p_world`` (REP 103 optical frame),
pixel centres at integer coordinates (u right, v down).
"""
from __future__ import annotations

from typing import Protocol, runtime_checkable

from numpy.typing import ArrayLike

from hand_tracker_ros._typing import FloatArray


@runtime_checkable
class Camera(Protocol):
    """A calibrated camera: image size, world pose, projection, its Jacobian, back-projection."""

    @property
    def name(self) -> str:
        """Camera name (e.g. 'cam0'), unique within a rig."""

    @property
    def width(self) -> int:
        """Image width (px)."""

    @property
    def height(self) -> int:
        """Image height (px)."""

    @property
    def T_cam_world(self) -> FloatArray:
        """(4, 4) float64 rigid transform, ``p_cam = T_cam_world @ p_world``."""

    @property
    def R_cam_world(self) -> FloatArray:
        """(3, 3) float64 rotation from world to camera axes."""

    @property
    def center_world(self) -> FloatArray:
        """(3,) float64 camera centre in the world frame (m)."""

    def project(self, points_world: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """World points (N, 3) to pixels ``uv_px (N, 2)`` (NaN behind the camera) and depths
        ``depth_m (N,)``."""

    def project_jacobian(self, points_world: ArrayLike
                         ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """As :meth:`project`, plus ``d(u, v)/d(X_world)`` (N, 2, 3) (px / m)."""

    def rays(self, uv_px: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Pixels (N, 2) to world rays: the origin (3,) and unit directions (N, 3)."""

    def scaled(self, width: int, height: int) -> Camera:
        """The same camera at another image resolution."""
