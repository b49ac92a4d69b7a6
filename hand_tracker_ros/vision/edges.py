"""Image edges with orientation, and whether query points lie near an edge.

Pixel convention: ``uv_px = (u, v) = (column, row)``, pixel centres at integer coordinates,
origin at the top-left pixel centre of the full image. The maps may cover only a region of
interest: map pixel ``(c, r)`` is image pixel ``(c, r) + offset_uv_px``. Every coordinate in
and out of the public functions is a full-image coordinate.

The gray image is optionally Gaussian-blurred, then differentiated once with 3x3 Sobel
(``g = (gx, gy)``, int16). Canny runs on these same derivatives (the ``cv2.Canny(dx, dy, ...)``
overload), so the gradient is computed once. The edge orientation is the gradient (normal)
direction ``theta = atan2(gy, gx)`` in [0, 2 pi) from ``cv2.phase``; an edge's tangent
is perpendicular to it.

Whether a query point lies near an image edge (the judge's edge coverage,
:mod:`hand_tracker_ros.tracking.evidence`) is an exact test on the edge pixels of the query's
square neighbourhood (:func:`edges_within`). A labelled distance transform of every frame
(nearest edge pixel of every pixel) answered it before; it cost 0.5-0.8 ms per 320x240
camera-frame, a quarter of the features' time, for a few hundred queries per camera and fit.

Orientation compatibility of two normals ``a`` and ``b`` is ``|cos(a - b)|`` in [0, 1]:
edge polarity (dark-to-bright vs bright-to-dark) is ignored because the hand can be brighter
or darker than the background.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import cast

import cv2
import numba
import numpy as np

from hand_tracker_ros._typing import BoolArray, Float32Array, FloatArray, UInt8Array
from hand_tracker_ros.checks import check_finite, check_shape
from hand_tracker_ros.config import param
from hand_tracker_ros.errors import ImageFormatError


@dataclass(frozen=True)
class EdgeConfig:
    """Canny edges and gradient orientation."""

    canny_low: float = param(50.0, 'Canny hysteresis low threshold on the Sobel gradient L1 '
                             'norm', low=0.0, high=10000.0)
    canny_high: float = param(150.0, 'Canny hysteresis high threshold', low=0.0,
                              high=10000.0)
    blur_sigma_px: float = param(1.0, 'Gaussian pre-blur sigma; 0 disables the blur',
                                 unit='px', low=0.0, high=10.0)
    l2_gradient: bool = param(False, 'Canny uses the L2 gradient norm instead of L1')


@dataclass(frozen=True)
class EdgeMap:
    """Edges of one image, or of a region of interest cut from it.

    Attributes
    ----------
    edges : (H, W) bool
        Canny edge pixels.
    orientation_rad : (H, W) float32
        Image-gradient (edge normal) direction ``atan2(gy, gx)`` in [0, 2 pi), at every pixel.
    offset_uv_px : (int, int)
        Full-image ``(u, v)`` of map pixel (0, 0); (0, 0) for a full-image map.
    """

    edges: BoolArray
    orientation_rad: Float32Array
    offset_uv_px: tuple[int, int] = (0, 0)

    @property
    def shape(self) -> tuple[int, int]:
        """``(H, W)`` of the maps (the ROI size)."""
        return (int(self.edges.shape[0]), int(self.edges.shape[1]))


def gradients(gray: UInt8Array, config: EdgeConfig) -> tuple[np.ndarray, np.ndarray]:
    """Sobel derivatives of the (optionally blurred) image.

    Parameters
    ----------
    gray : (H, W) uint8
    config : EdgeConfig

    Returns
    -------
    gx, gy : (H, W) int16
        d/du and d/dv of intensity (3x3 Sobel, so 8x the central difference scale).
    """
    src = gray
    if config.blur_sigma_px > 0.0:
        src = cast(UInt8Array, cv2.GaussianBlur(gray, (0, 0), config.blur_sigma_px))
    gx = cv2.Sobel(src, cv2.CV_16S, 1, 0, ksize=3)
    gy = cv2.Sobel(src, cv2.CV_16S, 0, 1, ksize=3)
    return gx, gy


def compute_edges(gray: UInt8Array, config: EdgeConfig, *,
                  offset_uv_px: tuple[int, int] = (0, 0)) -> EdgeMap:
    """Canny edges and gradient orientation of one image.

    Parameters
    ----------
    gray : (H, W) uint8
        Gray image, or a region of interest cut from it.
    config : EdgeConfig
    offset_uv_px : (int, int)
        Full-image ``(u, v)`` of ``gray[0, 0]``.

    Returns
    -------
    EdgeMap
    """
    if gray.ndim != 2 or gray.dtype != np.uint8:
        msg = f'gray: expected an (H, W) uint8 image, got shape {gray.shape} dtype {gray.dtype}'
        raise ImageFormatError(msg)
    gx, gy = gradients(gray, config)
    edges_u8 = cv2.Canny(gx, gy, config.canny_low, config.canny_high,
                         L2gradient=config.l2_gradient)
    orientation = cast(Float32Array, cv2.phase(gx.astype(np.float32), gy.astype(np.float32)))
    return EdgeMap(edges_u8 > 0, orientation, (int(offset_uv_px[0]), int(offset_uv_px[1])))


@numba.njit(cache=True, nogil=True)
def _edges_within(edges: BoolArray, u0: int, v0: int, uv: FloatArray,
                  radius: float) -> BoolArray:  # pragma: no cover - compiled
    height, width = edges.shape
    out = np.zeros(uv.shape[0], dtype=np.bool_)
    r2 = radius * radius
    for i in range(uv.shape[0]):
        u, v = uv[i, 0], uv[i, 1]
        for row in range(max(math.ceil(v - radius) - v0, 0),
                         min(math.floor(v + radius) - v0 + 1, height)):
            dv = row + v0 - v
            for col in range(max(math.ceil(u - radius) - u0, 0),
                             min(math.floor(u + radius) - u0 + 1, width)):
                du = col + u0 - u
                if edges[row, col] and du * du + dv * dv <= r2:
                    out[i] = True
                    break
            if out[i]:
                break
    return out


def edges_within(edge_map: EdgeMap, uv_px: FloatArray, radius_px: float) -> BoolArray:
    """Whether an edge pixel's centre lies within ``radius_px`` of each query point.

    numba: a scan of each query's square neighbourhood, a few hundred queries of a few
    pixels' radius per camera and fit, where a distance transform of the whole map cost a
    hundred times more (module docstring). Only the map's pixels count: a query outside the
    map (the image or the ROI) finds the map's edges within its reach.

    Parameters
    ----------
    edge_map : EdgeMap
    uv_px : (N, 2) float64
        Query points ``(u, v)``, full-image px, finite.
    radius_px : float
        Reach (px), >= 0.

    Returns
    -------
    near : (N,) bool
    """
    check_shape('uv_px', uv_px, (None, 2))
    check_finite('uv_px', uv_px)
    u0, v0 = edge_map.offset_uv_px
    return _edges_within(edge_map.edges, u0, v0,
                         np.ascontiguousarray(uv_px, dtype=np.float64), float(radius_px))


def orientation_compatibility(theta_a_rad: FloatArray, theta_b_rad: FloatArray) -> FloatArray:
    """``|cos(theta_a - theta_b)|``: 1 for parallel normals (either polarity), 0 at 90 deg.

    Parameters
    ----------
    theta_a_rad, theta_b_rad : (N,) float64
        Normal directions (broadcastable).

    Returns
    -------
    compat : (N,) float64 in [0, 1]
    """
    return np.abs(np.cos(np.asarray(theta_a_rad, dtype=np.float64)
                         - np.asarray(theta_b_rad, dtype=np.float64)))
