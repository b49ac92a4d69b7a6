"""Renderings of image features: what the `features` node publishes, and overlay images.

Flow colour wheel: hue encodes the direction ``atan2(dv, du)`` (0 deg = +u, red), value
encodes the magnitude scaled so that ``max_flow_px`` is full brightness; saturation is 1.
Invalid (NaN) flow is black.
"""
from __future__ import annotations

from typing import cast

import cv2
import numpy as np

from hand_tracker_ros._typing import BoolArray, Float32Array, UInt8Array
from hand_tracker_ros.vision.edges import EdgeMap
from hand_tracker_ros.vision.flow import DenseFlow, FlowField


def edge_image(edges: EdgeMap) -> UInt8Array:
    """Edge pixels as a mono8 image: (H, W) uint8, 255 on edges, else 0."""
    return np.where(edges.edges, 255, 0).astype(np.uint8)


def mask_image(mask: BoolArray) -> UInt8Array:
    """A (H, W) bool mask as a mono8 image: (H, W) uint8, 255 for True, else 0."""
    return np.where(mask, 255, 0).astype(np.uint8)


def flow_image(flow: FlowField) -> Float32Array:
    """Flow as a 32FC2 image.

    Parameters
    ----------
    flow : DenseFlow or SparseFlow

    Returns
    -------
    flow_px : (H, W, 2) float32
        Dense flow as is; for sparse tracks, each track's displacement at its (rounded)
        start pixel and NaN elsewhere. Covers the flow's ROI (paste with :func:`paste_roi`).
    """
    if isinstance(flow, DenseFlow):
        return flow.flow_px
    height, width = flow.shape
    out = np.full((height, width, 2), np.nan, dtype=np.float32)
    u0, v0 = flow.offset_uv_px
    cols = np.clip(np.rint(flow.pts_prev_px[:, 0]) - u0, 0, width - 1).astype(np.intp)
    rows = np.clip(np.rint(flow.pts_prev_px[:, 1]) - v0, 0, height - 1).astype(np.intp)
    out[rows, cols] = flow.pts_curr_px - flow.pts_prev_px
    return out


def paste_roi(roi_array: np.ndarray, roi_px: tuple[int, int, int, int],
              image_size_px: tuple[int, int], fill: float = 0) -> np.ndarray:
    """Place an ROI-sized array into a full-size one (for publishing full-size images).

    Parameters
    ----------
    roi_array : (h, w) or (h, w, k) array
        Covers ``roi_px``.
    roi_px : (u0, v0, u1, v1)
        Half-open box, inside the image.
    image_size_px : (int, int)
        ``(W, H)`` of the full image.
    fill : float
        Value outside the box (e.g. 0 for masks, NaN for float flow).

    Returns
    -------
    full : (H, W) or (H, W, k) array of ``roi_array.dtype``
        ``roi_array`` itself when the box is the whole image (not a copy).
    """
    u0, v0, u1, v1 = roi_px
    width, height = image_size_px
    if (u0, v0, u1, v1) == (0, 0, width, height):
        return roi_array
    out = np.full((height, width) + roi_array.shape[2:], fill, dtype=roi_array.dtype)
    out[v0:v1, u0:u1] = roi_array
    return out


def flow_to_rgb(flow_px: Float32Array, max_flow_px: float | None = None) -> UInt8Array:
    """Colour-wheel rendering of a flow image.

    Parameters
    ----------
    flow_px : (H, W, 2) float32
        May hold NaN (drawn black).
    max_flow_px : float, optional
        Magnitude drawn at full brightness; default: the largest finite magnitude.

    Returns
    -------
    image_rgb : (H, W, 3) uint8
    """
    finite = np.all(np.isfinite(flow_px), axis=2)
    clean = np.where(finite[..., None], flow_px, 0.0).astype(np.float32)
    magnitude, angle_deg = cv2.cartToPolar(clean[..., 0], clean[..., 1], angleInDegrees=True)
    scale = max_flow_px if max_flow_px is not None else float(magnitude.max(initial=0.0))
    hsv = np.empty(flow_px.shape[:2] + (3,), dtype=np.uint8)
    hsv[..., 0] = (angle_deg / 2.0).astype(np.uint8)  # OpenCV 8-bit hue spans [0, 180)
    hsv[..., 1] = 255
    hsv[..., 2] = np.clip(magnitude / max(scale, 1e-9) * 255.0, 0, 255).astype(np.uint8)
    hsv[~finite] = 0
    return cast(UInt8Array, cv2.cvtColor(hsv, cv2.COLOR_HSV2RGB))
