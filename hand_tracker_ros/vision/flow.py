"""Optical flow from the previous frame: dense DIS or sparse pyramidal Lucas-Kanade.

Both give a :data:`FlowField` that the flow energy queries with :meth:`flow_at`: for points
``uv_prev`` (N, 2) in the previous image it returns where they went, ``uv_curr``, and a
validity mask. Pixel convention as in :mod:`hand_tracker_ros.vision.edges`: all coordinates
are full-image ones, and a flow computed in a region of interest carries the full-image
``offset_uv_px`` of its pixel (0, 0).

- **Dense** (``'dis'``, Kroeger et al. ECCV 2016, ``cv2.DISOpticalFlow``): a flow image
  ``f`` (H, W, 2) with ``I_prev(p) ~ I_curr(p + f(p))``. ``flow_at`` samples ``f`` bilinearly
  at ``uv_prev``: with ``p = (u, v)``, ``u0 = floor(u)``, ``a = u - u0`` (same for ``v``),
  ``f(p) = (1-a)(1-b) f00 + a(1-b) f10 + (1-a) b f01 + a b f11``. Queries outside the pixel
  centre grid ``[0, W-1] x [0, H-1]`` (of the ROI) are invalid.
- **Sparse** (``'lk'``, ``cv2.calcOpticalFlowPyrLK`` on ``cv2.goodFeaturesToTrack`` corners):
  a track is kept only if tracking it forward then backward lands within
  ``lk_fb_threshold_px`` of where it started (Kalal et al. 2010). As in Ballan et al. 2012,
  each track is attached to the nearest query point within ``attach_radius_px``, and a query
  keeps only its closest attached track; it then moves by that track's displacement.
  Queries with no attached track are invalid.

A DIS object is stateful and not re-entrant: each :class:`FlowEstimator` owns one, so use one
estimator per camera/thread.

References: docs/references.md.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import cv2
import numba
import numpy as np
from scipy.spatial import cKDTree

from hand_tracker_ros._typing import BoolArray, Float32Array, FloatArray, UInt8Array
from hand_tracker_ros.checks import check_finite, check_shape
from hand_tracker_ros.config import param
from hand_tracker_ros.errors import ImageFormatError

FLOW_METHODS = ('dis', 'lk')
# Smallest image side accepted: DIS raises on images of a few px and, in opencv 5.0.0,
# segfaults on some 9-11 px sizes; 16 px and up was checked for every preset.
MIN_SIDE_PX = 16
_DIS_PRESETS = {
    'ultrafast': cv2.DISOPTICAL_FLOW_PRESET_ULTRAFAST,
    'fast': cv2.DISOPTICAL_FLOW_PRESET_FAST,
    'medium': cv2.DISOPTICAL_FLOW_PRESET_MEDIUM,
}


@dataclass(frozen=True)
class FlowConfig:
    """Optical flow from the previous frame."""

    method: str = param('dis', 'dense DIS flow or sparse Lucas-Kanade tracks',
                        choices=FLOW_METHODS)
    dis_preset: str = param('ultrafast', 'DIS speed/quality preset', choices=tuple(_DIS_PRESETS))
    lk_max_corners: int = param(300, 'LK: corners detected in the previous frame', low=1,
                                high=10000)
    lk_quality: float = param(0.01, 'LK: goodFeaturesToTrack quality level', low=1e-4,
                              high=1.0)
    lk_min_distance_px: float = param(5.0, 'LK: minimum corner spacing', unit='px', low=1.0,
                                      high=100.0)
    lk_window_px: int = param(15, 'LK: search window side', unit='px', low=5, high=101)
    lk_levels: int = param(2, 'LK: pyramid levels above the full image', low=0, high=8)
    lk_fb_threshold_px: float = param(1.0, 'LK: largest forward-backward error of a kept '
                                      'track', unit='px', low=0.01, high=50.0)
    attach_radius_px: float = param(3.0, 'LK: largest distance between a query point and '
                                    'the track attached to it', unit='px', low=0.1,
                                    high=50.0)


@dataclass(frozen=True)
class DenseFlow:
    """Dense flow from the previous to the current image.

    Attributes
    ----------
    flow_px : (H, W, 2) float32
        ``(du, dv)`` displacement of each previous-image pixel (of the ROI).
    offset_uv_px : (int, int)
        Full-image ``(u, v)`` of ``flow_px[0, 0]``.
    """

    flow_px: Float32Array
    offset_uv_px: tuple[int, int] = (0, 0)

    @property
    def shape(self) -> tuple[int, int]:
        """``(H, W)`` of the flow image (the ROI size)."""
        return (int(self.flow_px.shape[0]), int(self.flow_px.shape[1]))

    def flow_at(self, uv_prev_px: FloatArray) -> tuple[FloatArray, BoolArray]:
        """Bilinearly sampled flow at N previous-image points.

        Parameters
        ----------
        uv_prev_px : (N, 2) float64

        Returns
        -------
        uv_curr_px : (N, 2) float64
            ``uv_prev_px + flow``; equal to ``uv_prev_px`` where invalid.
        valid : (N,) bool
            Inside the pixel-centre grid and a finite flow.
        """
        check_shape('uv_prev_px', uv_prev_px, (None, 2))
        check_finite('uv_prev_px', uv_prev_px)
        return _sample_bilinear(np.ascontiguousarray(uv_prev_px, dtype=np.float64),
                                self.flow_px, float(self.offset_uv_px[0]),
                                float(self.offset_uv_px[1]))


# numba: the tracker samples the flow at the ~2k points visible at t-1 in every camera and
# frame, where the numpy form's dozen temporaries cost about 0.3 ms per camera. The arithmetic
# (float32 flow promoted to float64, the four products summed in this order) is the numpy
# form's, so the samples agree to the last bit.
@numba.njit(cache=True, nogil=True)
def _sample_bilinear(uv: FloatArray, flow: Float32Array, off_u: float, off_v: float
                     ) -> tuple[FloatArray, BoolArray]:  # pragma: no cover - compiled
    height, width = flow.shape[0], flow.shape[1]
    out = uv.copy()
    valid = np.zeros(uv.shape[0], dtype=np.bool_)
    for i in range(uv.shape[0]):
        u, v = uv[i, 0] - off_u, uv[i, 1] - off_v
        if not (0.0 <= u <= width - 1 and 0.0 <= v <= height - 1):
            continue
        # The upper corner is clamped so that u = W-1 exactly stays inside (a = 1 there).
        u0 = min(max(math.floor(u), 0), max(width - 2, 0))
        v0 = min(max(math.floor(v), 0), max(height - 2, 0))
        u1, v1 = min(u0 + 1, width - 1), min(v0 + 1, height - 1)
        a = min(max(u - u0, 0.0), 1.0)
        b = min(max(v - v0, 0.0), 1.0)
        du = ((1 - a) * (1 - b) * flow[v0, u0, 0] + a * (1 - b) * flow[v0, u1, 0]
              + (1 - a) * b * flow[v1, u0, 0] + a * b * flow[v1, u1, 0])
        dv = ((1 - a) * (1 - b) * flow[v0, u0, 1] + a * (1 - b) * flow[v0, u1, 1]
              + (1 - a) * b * flow[v1, u0, 1] + a * b * flow[v1, u1, 1])
        if math.isfinite(du) and math.isfinite(dv):
            valid[i] = True
            out[i, 0] += du
            out[i, 1] += dv
    return out, valid


@dataclass(frozen=True)
class SparseFlow:
    """Sparse tracks that passed the forward-backward check.

    Attributes
    ----------
    shape : (int, int)
        ``(H, W)`` of the image (or ROI) the tracks were computed in.
    pts_prev_px : (T, 2) float32
        Track start ``(u, v)`` in the previous image (full-image coordinates).
    pts_curr_px : (T, 2) float32
        Track end in the current image.
    attach_radius_px : float
        Largest query-to-track distance in :meth:`flow_at`.
    offset_uv_px : (int, int)
        Full-image ``(u, v)`` of the ROI's pixel (0, 0).
    """

    shape: tuple[int, int]
    pts_prev_px: Float32Array
    pts_curr_px: Float32Array
    attach_radius_px: float
    offset_uv_px: tuple[int, int] = (0, 0)

    def flow_at(self, uv_prev_px: FloatArray) -> tuple[FloatArray, BoolArray]:
        """Move each query point by its attached track (see the module docstring).

        Parameters
        ----------
        uv_prev_px : (N, 2) float64

        Returns
        -------
        uv_curr_px : (N, 2) float64
            ``uv_prev_px + track displacement``; equal to ``uv_prev_px`` where invalid.
        valid : (N,) bool
            The query has an attached track.
        """
        check_shape('uv_prev_px', uv_prev_px, (None, 2))
        check_finite('uv_prev_px', uv_prev_px)
        n = uv_prev_px.shape[0]
        out = uv_prev_px.astype(np.float64, copy=True)
        valid = np.zeros(n, dtype=bool)
        if n == 0 or self.pts_prev_px.shape[0] == 0:
            return out, valid
        dist, query = cKDTree(uv_prev_px).query(
            self.pts_prev_px, distance_upper_bound=self.attach_radius_px)
        attached = np.flatnonzero(np.isfinite(dist))
        # Closest track first, so the first occurrence of each query is its best track.
        attached = attached[np.lexsort((dist[attached], query[attached]))]
        _, first = np.unique(query[attached], return_index=True)
        best = attached[first]
        target = query[best]
        out[target] += (self.pts_curr_px[best] - self.pts_prev_px[best]).astype(np.float64)
        valid[target] = True
        return out, valid


FlowField = DenseFlow | SparseFlow


class FlowEstimator:
    """Flow between consecutive gray frames of one camera (owns its DIS object).

    Parameters
    ----------
    config : FlowConfig
    """

    def __init__(self, config: FlowConfig) -> None:
        self.config = config
        self._dis = (cv2.DISOpticalFlow.create(_DIS_PRESETS[config.dis_preset])
                     if config.method == 'dis' else None)
        self._lk_criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 20, 0.03)

    def compute(self, prev_gray: UInt8Array, curr_gray: UInt8Array,
                prev_mask: np.ndarray | None = None, *,
                offset_uv_px: tuple[int, int] = (0, 0)) -> FlowField:
        """Flow from ``prev_gray`` to ``curr_gray``.

        Parameters
        ----------
        prev_gray, curr_gray : (H, W) uint8
            Same size, at least ``MIN_SIDE_PX`` per side: whole images, or the same ROI cut
            from both.
        prev_mask : (H, W) bool, optional
            LK only: detect corners only where True (e.g. the dilated hand mask).
        offset_uv_px : (int, int)
            Full-image ``(u, v)`` of the ROI's pixel (0, 0).

        Returns
        -------
        DenseFlow (method 'dis') or SparseFlow (method 'lk')
        """
        if prev_gray.shape != curr_gray.shape or prev_gray.ndim != 2:
            msg = (f'flow needs two (H, W) gray images of one size, got {prev_gray.shape} '
                   f'and {curr_gray.shape}')
            raise ImageFormatError(msg)
        if min(prev_gray.shape) < MIN_SIDE_PX:
            msg = (f'flow needs images (or ROIs) of at least {MIN_SIDE_PX} px per side, got '
                   f'{prev_gray.shape[1]}x{prev_gray.shape[0]}')
            raise ImageFormatError(msg)
        prev_gray = np.ascontiguousarray(prev_gray)
        curr_gray = np.ascontiguousarray(curr_gray)
        offset = (int(offset_uv_px[0]), int(offset_uv_px[1]))
        if self._dis is not None:
            # None: DIS allocates the flow (opencv's stub wants an array there).
            flow_px = self._dis.calc(prev_gray, curr_gray, None)  # type: ignore[call-overload]
            return DenseFlow(flow_px, offset)
        return self._lucas_kanade(prev_gray, curr_gray, prev_mask, offset)

    def _lucas_kanade(self, prev_gray: UInt8Array, curr_gray: UInt8Array,
                      prev_mask: np.ndarray | None, offset: tuple[int, int]) -> SparseFlow:
        cfg = self.config
        mask_u8 = None if prev_mask is None else np.asarray(prev_mask, dtype=np.uint8)
        corners = cv2.goodFeaturesToTrack(prev_gray, cfg.lk_max_corners, cfg.lk_quality,
                                          cfg.lk_min_distance_px, mask=mask_u8)
        shape = (int(prev_gray.shape[0]), int(prev_gray.shape[1]))
        empty = np.zeros((0, 2), dtype=np.float32)
        if corners is None:
            return SparseFlow(shape, empty, empty, cfg.attach_radius_px, offset)
        lk: dict[str, Any] = {'winSize': (cfg.lk_window_px, cfg.lk_window_px),
                              'maxLevel': cfg.lk_levels, 'criteria': self._lk_criteria}
        # nextPts None: OpenCV allocates the tracked points (its stub wants an array there).
        fwd, st_f, _ = cv2.calcOpticalFlowPyrLK(  # type: ignore[call-overload]
            prev_gray, curr_gray, corners, None, **lk)
        back, st_b, _ = cv2.calcOpticalFlowPyrLK(  # type: ignore[call-overload]
            curr_gray, prev_gray, fwd, None, **lk)
        p0, p1, pb = corners.reshape(-1, 2), fwd.reshape(-1, 2), back.reshape(-1, 2)
        fb_err = np.hypot(*(p0 - pb).T)
        keep = (st_f.ravel() == 1) & (st_b.ravel() == 1) & (fb_err < cfg.lk_fb_threshold_px)
        shift = np.array(offset, dtype=np.float32)
        return SparseFlow(shape, p0[keep] + shift, p1[keep] + shift, cfg.attach_radius_px,
                          offset)
