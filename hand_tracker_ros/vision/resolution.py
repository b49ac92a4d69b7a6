"""The tracking resolution: images wider than a working width are scaled down with their camera.

The tracker's cost grows with the pixels it observes (features, detection, the model's
rendering and silhouette). A live tracker that cannot keep up with a 640x480 rig skips sets,
and the motion between the sets it keeps breaks its warm start; from 320 px it keeps up
like a 320x240 rig, at about twice the error of 640 px offline (README, "Live, in real
time"). Each image wider than ``width_px`` is resized to ``width_px``
(``cv2.INTER_AREA``, the height by the same factor, rounded) before the features and the
detector see it, and the camera the tracker fits with is :meth:`Camera.scaled` to that size
(the intrinsics follow; pose and distortion stay). Estimates stay in metres.
"""
from __future__ import annotations

from typing import cast

import cv2

from hand_tracker_ros._typing import UInt8Array
from hand_tracker_ros.errors import ShapeError
from hand_tracker_ros.geometry.camera_model import Camera

# The live graph's working width (px): the tracker node's, and the distributed features and
# salient_points nodes', which must observe at the tracker's size.
LIVE_WIDTH_PX = 320


def working_size(width: int, height: int, width_px: int) -> tuple[int, int]:
    """(width, height) in px of a ``width`` x ``height`` image at the working width
    ``width_px``: scaled down to it if wider, the height by the same factor (rounded);
    unchanged otherwise (also for 0)."""
    if width_px <= 0 or width <= width_px:
        return width, height
    return width_px, max(1, round(height * width_px / width))


def working_camera(camera: Camera, width_px: int) -> Camera:
    """``camera`` scaled to ``width_px`` wide if it is wider; else itself (also for 0)."""
    size = working_size(camera.width, camera.height, width_px)
    return camera if size == (camera.width, camera.height) else camera.scaled(*size)


def to_width(image: UInt8Array, width_px: int) -> UInt8Array:
    """``image`` (H, W[, C]) uint8 at the working width ``width_px`` (as it is, or resized
    down): what a node without the rig (the distributed features and salient_points) observes,
    the same size as :func:`working_camera` gives the tracker."""
    height, width = image.shape[:2]
    size = working_size(width, height, width_px)
    if size == (width, height):
        return image
    return cast(UInt8Array, cv2.resize(image, size, interpolation=cv2.INTER_AREA))


def to_working(image: UInt8Array, camera: Camera) -> UInt8Array:
    """``image`` (H, W[, C]) uint8 at ``camera``'s size: as it is, or resized down."""
    height, width = image.shape[:2]
    if (width, height) == (camera.width, camera.height):
        return image
    if width < camera.width or height < camera.height:
        msg = (f'{camera.name}: a {width}x{height} image cannot be scaled down to the '
               f'working {camera.width}x{camera.height}')
        raise ShapeError(msg)
    return cast(UInt8Array, cv2.resize(image, (camera.width, camera.height),
                                       interpolation=cv2.INTER_AREA))
