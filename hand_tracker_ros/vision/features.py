"""Per-camera image features (edges, foreground mask, optical flow) and a multi-camera pool.

A :class:`FeatureExtractor` holds one camera's state between frames: the previous gray image
(for flow), the background model (for the mask) and its own DIS object. After a
:meth:`~FeatureExtractor.reset` or an image size change, the next frame has no flow.

Features can be computed only in a region of interest ``roi_px = (u0, v0, u1, v1)`` (e.g. the
predicted hand box plus a margin), measured 4-5x cheaper at 640x480 (bench/bench_features.py). The
maps then cover that box only; every coordinate going in or out of ``EdgeMap``, the flow and
:meth:`CameraFeatures.mask_at` stays a full-image one. Flow compares the same box cut from
the previous and current frames, so it is valid even when the box moves.

:class:`MultiCameraFeatures` runs the C extractors in a thread pool. cv2 releases the GIL,
so plain threads run cameras in parallel. cv2's own threading is turned down to 1 thread
(process-wide: ``cv2.setNumThreads`` is global): Canny and Sobel are single-threaded
anyway, and on 2 cores one camera per worker measured 1.6-2x faster than cv2 splitting each
call (bench/bench_features.py), because nested parallelism only adds synchronisation when
every core is already busy with a camera.
"""
from __future__ import annotations

from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import cached_property

import cv2
import numba
import numpy as np

from hand_tracker_ros._typing import BoolArray, FloatArray, IntArray, UInt8Array
from hand_tracker_ros.checks import check_finite, check_rgb, check_shape
from hand_tracker_ros.config import nested, param
from hand_tracker_ros.errors import ConfigError, ShapeError
from hand_tracker_ros.vision.edges import EdgeConfig, EdgeMap, compute_edges
from hand_tracker_ros.vision.flow import FlowConfig, FlowEstimator, FlowField
from hand_tracker_ros.vision.image import clip_roi, to_gray
from hand_tracker_ros.vision.mask import ForegroundMasker, MaskConfig


@dataclass(frozen=True)
class FeaturesConfig:
    """Per-camera image features."""

    edges: EdgeConfig = nested(EdgeConfig)
    mask: MaskConfig = nested(MaskConfig)
    flow: FlowConfig = nested(FlowConfig)
    flow_enabled: bool = param(True, 'compute optical flow from the previous frame')
    lk_mask_dilate_px: int = param(15, 'LK: corners are detected in the foreground mask '
                                   'dilated by this much; 0: in the whole image', unit='px',
                                   low=0, high=200)


@dataclass(frozen=True)
class CameraFeatures:
    """Features of one camera frame.

    Attributes
    ----------
    camera_name : str
    stamp_ns : int
        Stamp of the image.
    edges : EdgeMap
    mask : (h, w) bool
        Foreground (hand) mask of the ROI.
    flow : DenseFlow or SparseFlow or None
        Flow from the previous frame of this camera; None on the first frame, after a reset
        or a size change, or when flow is disabled.
    gray : (h, w) uint8 or None
        Gray image of the ROI; None when the features were rebuilt from the ``features``
        node's topics, which do not carry it (no energy reads it).
    roi_px : (u0, v0, u1, v1)
        Half-open full-image box covered by ``edges``, ``mask``, ``gray`` and a dense flow;
        ``(0, 0, W, H)`` without ROI.
    image_size_px : (int, int)
        ``(W, H)`` of the full image.
    """

    camera_name: str
    stamp_ns: int
    edges: EdgeMap
    mask: BoolArray
    flow: FlowField | None
    gray: UInt8Array | None
    roi_px: tuple[int, int, int, int]
    image_size_px: tuple[int, int]

    def mask_at(self, uv_px: FloatArray) -> BoolArray:
        """Foreground test of N full-image points (nearest pixel; False outside the ROI).

        Parameters
        ----------
        uv_px : (N, 2) float64

        Returns
        -------
        inside : (N,) bool
        """
        check_shape('uv_px', uv_px, (None, 2))
        check_finite('uv_px', uv_px)
        return _mask_at(self.mask, self.roi_px[0], self.roi_px[1],
                        np.ascontiguousarray(uv_px, dtype=np.float64))

    @cached_property
    def silhouette_px(self) -> IntArray:
        """Full-image ``(u, v)`` (K, 2) int64 of the foreground pixels with a background
        4-neighbour (the ROI border does not count as background); computed once per frame,
        although every correspondence round reads it."""
        # Only the foreground's bounding box grown by one pixel (background around it).
        wu0, wv0, wu1, wv1 = _foreground_box(self.mask, self.roi_px, 1)
        if wu1 == wu0:
            return np.zeros((0, 2), dtype=np.int64)
        u0, v0 = self.roi_px[:2]
        mask = self.mask[wv0 - v0:wv1 - v0, wu0 - u0:wu1 - u0].astype(np.uint8)
        # cv2.erode pads with the maximum by default, so the ROI border keeps its pixels.
        inner = cv2.erode(mask, cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3)))
        rows, cols = np.nonzero(mask > inner)
        return np.column_stack([cols + wu0, rows + wv0]).astype(np.int64)

    def nearest_foreground(self, reach_px: int) -> NearestForeground:
        """Closest foreground pixel of every pixel within about ``reach_px`` of the
        foreground; computed once per frame and reach, although every correspondence round
        reads it.

        Closest by ``cv2.distanceTransformWithLabels`` (``DIST_L2``, 5x5 mask) of the mask's
        complement, a chamfer approximation of the Euclidean distance, on the foreground's
        bounding box grown by ``reach_px`` (clipped to the ROI). A pixel less than
        ``reach_px - 1`` from the foreground gets the label a transform of the whole ROI gives
        it: every chamfer path that leaves the window is longer than that.

        Parameters
        ----------
        reach_px : int
            Margin (px) of the window around the foreground, >= 0.
        """
        cache = self.__dict__.setdefault('_nearest_foreground', {})
        if reach_px not in cache:
            cache[reach_px] = _nearest_foreground(self.mask, self.roi_px, reach_px)
        return cache[reach_px]


# Hand-written instead of numpy: the edge and silhouette terms probe a few hundred points
# per camera and round, where the numpy form's rounding, bounds mask and gather temporaries
# cost ~20 us a call against ~2 us here; the test compares it with the numpy form.
@numba.njit(cache=True, nogil=True)
def _mask_at(mask: BoolArray, u0: int, v0: int,
             uv: FloatArray) -> BoolArray:  # pragma: no cover - compiled
    height, width = mask.shape
    out = np.zeros(uv.shape[0], dtype=np.bool_)
    for i in range(uv.shape[0]):
        col, row = int(np.rint(uv[i, 0])) - u0, int(np.rint(uv[i, 1])) - v0
        if 0 <= col < width and 0 <= row < height:
            out[i] = mask[row, col]
    return out


@dataclass(frozen=True, eq=False)
class NearestForeground:
    """The closest foreground pixel of every pixel of a window (see
    :meth:`CameraFeatures.nearest_foreground`).

    Attributes
    ----------
    window_px : (u0, v0, u1, v1)
        Half-open full-image box, empty (``u1 == u0``) when the mask is.
    index : (h, w) int64
        Window raster index ``row * w + col`` of the foreground pixel closest to each window
        pixel (a foreground pixel is its own); no foreground lies outside the window.
    """

    window_px: tuple[int, int, int, int]
    index: IntArray


def _foreground_box(mask: BoolArray, roi_px: tuple[int, int, int, int], margin_px: int
                    ) -> tuple[int, int, int, int]:
    """Full-image half-open bounding box of ``mask`` (h, w) bool grown by ``margin_px``,
    clipped to ``roi_px``; ``(u0, v0, u0, v0)`` when the mask is empty."""
    u0, v0, u1, v1 = roi_px
    x, y, w, h = cv2.boundingRect(mask.view(np.uint8))
    if w == 0:
        return u0, v0, u0, v0
    return (max(u0 + x - margin_px, u0), max(v0 + y - margin_px, v0),
            min(u0 + x + w + margin_px, u1), min(v0 + y + h + margin_px, v1))


def _nearest_foreground(mask: BoolArray, roi_px: tuple[int, int, int, int], reach_px: int
                        ) -> NearestForeground:
    box = _foreground_box(mask, roi_px, reach_px)
    wu0, wv0, wu1, wv1 = box
    u0, v0 = roi_px[:2]
    window = mask[wv0 - v0:wv1 - v0, wu0 - u0:wu1 - u0]
    if window.size == 0:
        return NearestForeground(box, np.zeros((0, 0), dtype=np.int64))
    # distanceTransform measures the distance to the nearest zero pixel: foreground -> 0.
    # With DIST_LABEL_PIXEL the zero pixels are labelled 1..K in raster order.
    _, labels = cv2.distanceTransformWithLabels(
        np.logical_not(window).view(np.uint8), cv2.DIST_L2, 5, labelType=cv2.DIST_LABEL_PIXEL)
    return NearestForeground(box, np.flatnonzero(window)[labels - 1])


class FeatureExtractor:
    """Features of one camera's frames, in order (not thread-safe: one per camera).

    Parameters
    ----------
    camera_name : str
    config : FeaturesConfig
    """

    def __init__(self, camera_name: str, config: FeaturesConfig) -> None:
        self.camera_name = camera_name
        self.config = config
        self._masker = ForegroundMasker(config.mask)
        self._flow = FlowEstimator(config.flow)
        self._prev_gray: UInt8Array | None = None
        # Previous frame's mask with the ROI it covers.
        self._prev_mask: tuple[BoolArray, tuple[int, int, int, int]] | None = None
        self._kernel = (cv2.getStructuringElement(
            cv2.MORPH_ELLIPSE, (2 * config.lk_mask_dilate_px + 1,) * 2)
            if config.lk_mask_dilate_px > 0 else None)

    @property
    def masker(self) -> ForegroundMasker:
        """The camera's foreground masker (to set a background or fit the skin model)."""
        return self._masker

    def reset(self) -> None:
        """Forget the previous frame and the learned background."""
        self._prev_gray, self._prev_mask = None, None
        self._masker.reset()

    def process(self, image_rgb: UInt8Array, stamp_ns: int,
                provided_mask: np.ndarray | None = None, *,
                roi_px: tuple[int, int, int, int] | None = None) -> CameraFeatures:
        """Features of the next frame.

        Parameters
        ----------
        image_rgb : (H, W, 3) uint8
            The whole frame.
        stamp_ns : int
        provided_mask : (H, W) bool or uint8, optional
            Mask image for mask method 'provided'.
        roi_px : (u0, v0, u1, v1), optional
            Compute features only in this half-open box (clipped to the image); None: the
            whole image.

        Returns
        -------
        CameraFeatures
        """
        check_rgb(self.camera_name, image_rgb)
        height, width = image_rgb.shape[:2]
        roi = clip_roi(self.camera_name, roi_px, width, height)
        u0, v0, u1, v1 = roi
        gray_full = to_gray(image_rgb)
        if self._prev_gray is not None and self._prev_gray.shape != gray_full.shape:
            self._prev_gray, self._prev_mask = None, None
        mask = self._masker.compute(image_rgb, provided_mask, roi_px=roi)
        gray = gray_full[v0:v1, u0:u1]
        edges = compute_edges(gray, self.config.edges, offset_uv_px=(u0, v0))
        flow = None
        if self.config.flow_enabled and self._prev_gray is not None:
            flow = self._flow.compute(self._prev_gray[v0:v1, u0:u1], gray,
                                      self._lk_region(roi), offset_uv_px=(u0, v0))
        self._prev_gray, self._prev_mask = gray_full, (mask, roi)
        return CameraFeatures(camera_name=self.camera_name, stamp_ns=int(stamp_ns),
                              edges=edges, mask=mask, flow=flow, gray=gray, roi_px=roi,
                              image_size_px=(width, height))

    def _lk_region(self, roi: tuple[int, int, int, int]) -> np.ndarray | None:
        """Where LK looks for corners in ``roi``: the dilated previous mask, or everywhere."""
        if self.config.flow.method != 'lk' or self._kernel is None or self._prev_mask is None:
            return None
        prev_mask, (pu0, pv0, pu1, pv1) = self._prev_mask
        if not prev_mask.any():
            return None
        # The previous mask covers the previous ROI: paste it into a full-size image first.
        assert self._prev_gray is not None     # set with the previous mask
        full = np.zeros(self._prev_gray.shape, dtype=np.uint8)
        full[pv0:pv1, pu0:pu1] = prev_mask
        u0, v0, u1, v1 = roi
        return cv2.dilate(full[v0:v1, u0:u1], self._kernel)


class MultiCameraFeatures:
    """Extractors of C cameras run in a thread pool, one camera per task.

    Parameters
    ----------
    camera_names : sequence of str
        C distinct names.
    config : FeaturesConfig
    max_workers : int
        Worker threads (the machine's core count is a good value).

    Notes
    -----
    Construction calls ``cv2.setNumThreads(1)``, which affects the whole process (see the
    module docstring for why).
    """

    def __init__(self, camera_names: Sequence[str], config: FeaturesConfig, *,
                 max_workers: int = 2) -> None:
        names = tuple(camera_names)
        if not names or len(set(names)) != len(names):
            msg = f'camera names must be non-empty and distinct, got {list(names)}'
            raise ConfigError(msg)
        self.camera_names = names
        self.extractors = tuple(FeatureExtractor(name, config) for name in names)
        cv2.setNumThreads(1)
        self._pool = ThreadPoolExecutor(max_workers=max_workers,
                                        thread_name_prefix='features')

    def process(self, images_rgb: Sequence[UInt8Array], stamp_ns: int | Sequence[int],
                provided_masks: Sequence[np.ndarray | None] | None = None,
                rois_px: Sequence[tuple[int, int, int, int] | None] | None = None
                ) -> tuple[CameraFeatures, ...]:
        """Features of one synchronised set of C frames.

        Parameters
        ----------
        images_rgb : C arrays (H_c, W_c, 3) uint8
            In ``camera_names`` order.
        stamp_ns : int or C ints
            One stamp for all cameras, or one per camera.
        provided_masks : C arrays or None, optional
            Mask images for mask method 'provided'.
        rois_px : C boxes (u0, v0, u1, v1) or None, optional
            Per-camera region of interest (None: whole image).

        Returns
        -------
        tuple of C CameraFeatures, in ``camera_names`` order.
        """
        n = len(self.extractors)
        stamps = [stamp_ns] * n if isinstance(stamp_ns, (int, np.integer)) else list(stamp_ns)
        masks = [None] * n if provided_masks is None else list(provided_masks)
        rois = [None] * n if rois_px is None else list(rois_px)
        if not len(images_rgb) == len(stamps) == len(masks) == len(rois) == n:
            msg = (f'expected {n} images, stamps, masks and rois (one per camera), got '
                   f'{len(images_rgb)}, {len(stamps)}, {len(masks)} and {len(rois)}')
            raise ShapeError(msg)
        futures = [self._pool.submit(ex.process, img, st, m, roi_px=roi)
                   for ex, img, st, m, roi in zip(self.extractors, images_rgb, stamps, masks,
                                                   rois)]
        return tuple(f.result() for f in futures)

    def close(self) -> None:
        """Stop the worker threads."""
        self._pool.shutdown(wait=True)

    def __enter__(self) -> MultiCameraFeatures:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
