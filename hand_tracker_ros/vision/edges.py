"""Image edges with orientation, and the nearest edge pixel of any query point.

Pixel convention: ``uv_px = (u, v) = (column, row)``, pixel centres at integer coordinates,
origin at the top-left pixel centre of the full image. The maps may cover only a region of
interest: map pixel ``(c, r)`` is image pixel ``(c, r) + offset_uv_px``. Every coordinate in
and out of the public functions is a full-image coordinate.

The gray image is optionally Gaussian-blurred, then differentiated once with 3x3 Sobel
(``g = (gx, gy)``, int16). Canny runs on these same derivatives (the ``cv2.Canny(dx, dy, ...)``
overload), so the gradient is computed once. The edge orientation is the gradient (normal)
direction ``theta = atan2(gy, gx)`` in [0, 2 pi) from ``cv2.phase``; an edge's tangent
is perpendicular to it.

For correspondence search every pixel gets the Euclidean distance to, and the label of, its
nearest edge pixel from ``cv2.distanceTransformWithLabels(..., DIST_LABEL_PIXEL)``. Its 5x5
chamfer propagation is approximate: on textured test images the labelled edge pixel is the
exact nearest one for ~85% of pixels and otherwise at most ~4% (0.5 px + 0.04 d) farther than
the true nearest distance ``d``, which is negligible for the truncated edge energy. cv2 numbers
the edge pixels 1..E in raster order, so label ``k`` is row ``k - 1`` of
``edge_uv_px = flatnonzero(edges)`` unravelled: a lookup is two gathers.

Orientation compatibility of two normals ``a`` and ``b`` is ``|cos(a - b)|`` in [0, 1]:
edge polarity (dark-to-bright vs bright-to-dark) is ignored because the hand can be brighter
or darker than the background.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from hand_tracker_ros._typing import BoolArray, Float32Array, FloatArray, Int32Array, UInt8Array
from hand_tracker_ros.checks import check_finite, check_shape
from hand_tracker_ros.config import param
from hand_tracker_ros.errors import ImageFormatError


@dataclass(frozen=True)
class EdgeConfig:
    """Canny edges, gradient orientation and nearest-edge distance transform."""

    canny_low: float = param(50.0, 'Canny hysteresis low threshold on the Sobel gradient L1 '
                             'norm', low=0.0, high=10000.0)
    canny_high: float = param(150.0, 'Canny hysteresis high threshold', low=0.0,
                              high=10000.0)
    blur_sigma_px: float = param(1.0, 'Gaussian pre-blur sigma; 0 disables the blur',
                                 unit='px', low=0.0, high=10.0)
    l2_gradient: bool = param(False, 'Canny uses the L2 gradient norm instead of L1')


@dataclass(frozen=True)
class EdgeMap:
    """Edges of one image and their nearest-edge lookup tables.

    Attributes
    ----------
    edges : (H, W) bool
        Canny edge pixels.
    orientation_rad : (H, W) float32
        Image-gradient (edge normal) direction ``atan2(gy, gx)`` in [0, 2 pi), at every pixel.
    distance_px : (H, W) float32
        Distance from each pixel centre to the nearest edge pixel centre (>= 1e4 if the image
        has no edge).
    labels : (H, W) int32
        1-based index into ``edge_uv_px`` of each pixel's nearest edge pixel (0 if no edge).
    edge_uv_px : (E, 2) int32
        Full-image ``(u, v)`` of every edge pixel, in raster order.
    offset_uv_px : (int, int)
        Full-image ``(u, v)`` of map pixel (0, 0); (0, 0) for a full-image map.
    """

    edges: BoolArray
    orientation_rad: Float32Array
    distance_px: Float32Array
    labels: Int32Array
    edge_uv_px: Int32Array
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
        src = cv2.GaussianBlur(gray, (0, 0), config.blur_sigma_px)
    gx = cv2.Sobel(src, cv2.CV_16S, 1, 0, ksize=3)
    gy = cv2.Sobel(src, cv2.CV_16S, 0, 1, ksize=3)
    return gx, gy


def compute_edges(gray: UInt8Array, config: EdgeConfig, *,
                  offset_uv_px: tuple[int, int] = (0, 0)) -> EdgeMap:
    """Canny edges, gradient orientation and labelled distance transform of one image.

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
    orientation = cv2.phase(gx.astype(np.float32), gy.astype(np.float32))
    return edge_map_from(edges_u8 > 0, orientation, offset_uv_px=offset_uv_px)


def edge_map_from(edges: BoolArray, orientation_rad: Float32Array, *,
                  offset_uv_px: tuple[int, int] = (0, 0)) -> EdgeMap:
    """The lookup tables of given edge pixels (e.g. after synthetic edge noise).

    Parameters
    ----------
    edges : (H, W) bool
    orientation_rad : (H, W) float32
        Edge-normal direction per pixel.
    offset_uv_px : (int, int)
        Full-image ``(u, v)`` of pixel ``[0, 0]``.
    """
    edges_u8 = np.where(edges, np.uint8(255), np.uint8(0))
    # distanceTransform measures the distance to the nearest *zero* pixel: edges become 0.
    distance, labels = cv2.distanceTransformWithLabels(
        cv2.bitwise_not(edges_u8), cv2.DIST_L2, 5, labelType=cv2.DIST_LABEL_PIXEL)
    flat = np.flatnonzero(edges)
    width = edges.shape[1]
    edge_uv = np.empty((flat.size, 2), dtype=np.int32)
    edge_uv[:, 0] = flat % width + offset_uv_px[0]
    edge_uv[:, 1] = flat // width + offset_uv_px[1]
    return EdgeMap(edges=np.asarray(edges, bool), orientation_rad=orientation_rad,
                   distance_px=distance, labels=labels, edge_uv_px=edge_uv,
                   offset_uv_px=(int(offset_uv_px[0]), int(offset_uv_px[1])))


def nearest_edges(edge_map: EdgeMap, uv_px: FloatArray
                  ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Nearest edge pixel, its distance and its orientation, for N query points.

    A query is rounded to its pixel; queries outside the maps (the image or the ROI) are
    clamped to the nearest border pixel for the lookup, so they still get the edge pixel
    nearest to that border pixel (not necessarily the globally nearest one), while the
    returned distance is always the true Euclidean distance from the unclamped query to the
    returned edge pixel.

    Parameters
    ----------
    edge_map : EdgeMap
    uv_px : (N, 2) float64
        Query points ``(u, v)``, finite.

    Returns
    -------
    edge_uv_px : (N, 2) float64
        ``(u, v)`` of the nearest edge pixel; NaN if the image has no edge.
    distance_px : (N,) float64
        ``||uv_px - edge_uv_px||``; +inf if the image has no edge.
    orientation_rad : (N,) float64
        Gradient direction at the edge pixel in [0, 2 pi); NaN if the image has no edge.
    """
    check_shape('uv_px', uv_px, (None, 2))
    check_finite('uv_px', uv_px)
    n = uv_px.shape[0]
    if edge_map.edge_uv_px.shape[0] == 0:
        nan = np.full(n, np.nan)
        return np.full((n, 2), np.nan), np.full(n, np.inf), nan
    height, width = edge_map.shape
    u0, v0 = edge_map.offset_uv_px
    col = np.clip(np.rint(uv_px[:, 0]) - u0, 0, width - 1).astype(np.intp)
    row = np.clip(np.rint(uv_px[:, 1]) - v0, 0, height - 1).astype(np.intp)
    idx = edge_map.labels[row, col] - 1
    edge_int = edge_map.edge_uv_px[idx]
    edge_uv = edge_int.astype(np.float64)
    distance = np.hypot(uv_px[:, 0] - edge_uv[:, 0], uv_px[:, 1] - edge_uv[:, 1])
    orientation = edge_map.orientation_rad[edge_int[:, 1] - v0,
                                           edge_int[:, 0] - u0].astype(np.float64)
    return edge_uv, distance, orientation


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
