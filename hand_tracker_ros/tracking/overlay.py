"""The estimate drawn on a camera image: model silhouette contour and skeleton.

For a visual check of the fit: the observed foreground mask (or edge image) in gray, the
outline of the rendered model silhouette in green and the projected skeleton in red, so a
misfit shows as green/red away from the white hand.
"""
from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np

from hand_tracker_ros._typing import BoolArray, FloatArray, UInt8Array
from hand_tracker_ros.checks import check_shape
from hand_tracker_ros.core.observations import FrameObservations
from hand_tracker_ros.core.views import ModelView
from hand_tracker_ros.model.hand import PosedHand
from hand_tracker_ros.model.skeleton import KEYPOINT_NAMES
from hand_tracker_ros.vision.visualize import paste_roi

# Keypoints are the wrist, then four per finger from the base joint to the tip
# (skeleton.KEYPOINT_NAMES), so a finger's base hangs from the wrist and the rest chain.
KEYPOINT_PARENTS: tuple[int, ...] = (-1, *(0 if (k - 1) % 4 == 0 else k - 1
                                           for k in range(1, len(KEYPOINT_NAMES))))
CONTOUR_RGB = (0, 255, 0)
SKELETON_RGB = (255, 40, 40)


def draw_overlay(base: UInt8Array, model_mask: BoolArray, keypoints_uv_px: FloatArray,
                 parents: Sequence[int] = KEYPOINT_PARENTS) -> UInt8Array:
    """Draw the model outline and skeleton on a gray image.

    Parameters
    ----------
    base : (H, W) uint8
        Image to draw on (e.g. the foreground mask or the edge image, 0/255).
    model_mask : (H, W) bool
        Rendered model silhouette in this camera.
    keypoints_uv_px : (K, 2) float64
        Projected keypoints (NaN behind the camera: those bones are skipped).
    parents : sequence of int
        Parent keypoint of each keypoint (-1 for the root).

    Returns
    -------
    overlay : (H, W, 3) uint8
        RGB image.
    """
    check_shape('base', base, (None, None))
    check_shape('model_mask', model_mask, base.shape)
    check_shape('keypoints_uv_px', keypoints_uv_px, (len(parents), 2))
    # Dimmed so that the drawing stays visible on white foreground.
    out = cv2.cvtColor((base // 2).astype(np.uint8), cv2.COLOR_GRAY2RGB)
    contours, _ = cv2.findContours(model_mask.astype(np.uint8), cv2.RETR_EXTERNAL,
                                   cv2.CHAIN_APPROX_SIMPLE)
    cv2.drawContours(out, contours, -1, CONTOUR_RGB, 1, cv2.LINE_8)
    finite = np.all(np.isfinite(keypoints_uv_px), axis=1)
    # Clipped far outside the image so that int conversion cannot overflow.
    uv = np.rint(np.clip(np.nan_to_num(keypoints_uv_px), -1e4, 1e4)).astype(np.int32)
    for child, parent in enumerate(parents):
        if parent >= 0 and finite[child] and finite[parent]:
            cv2.line(out, tuple(uv[parent]), tuple(uv[child]), SKELETON_RGB, 1, cv2.LINE_8)
    for point in uv[finite]:
        cv2.circle(out, tuple(point), 2, SKELETON_RGB, -1, cv2.LINE_8)
    return np.asarray(out, np.uint8)


def observation_overlays(posed: PosedHand, views: Sequence[ModelView],
                         observations: FrameObservations, source: str = 'mask'
                         ) -> list[UInt8Array]:
    """Per camera, (H, W, 3) uint8: :func:`draw_overlay` of the estimate ``posed`` (rendered
    as ``views``) on the observed ``source`` (``'mask'`` or ``'edges'``), full image size."""
    images = []
    for obs, view in zip(observations.cameras, views):
        feats = obs.features
        base = feats.mask if source == 'mask' else feats.edges.edges
        full = paste_roi(np.where(base, np.uint8(255), np.uint8(0)), feats.roi_px,
                         feats.image_size_px)
        uv, _ = obs.camera.project(posed.keypoints_m)
        images.append(draw_overlay(full, view.raster.mask, uv))
    return images
