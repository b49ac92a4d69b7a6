r"""Fingertip detection with a Hough forest: unlabelled tip candidates (u, v, score) per image.

Why a Hough forest (Gall & Lempitsky 2009; the detector family Ballan et al. 2012 used):
fingertips are small, have no texture of their own, and are defined by the *shape* of the
skin region around them, which pixel-pair tests over a window capture cheaply; the forest
combines classification ("is a tip within R px?") with a learned offset to the tip centre,
so every skin pixel near a tip votes for the same centre and the evidence adds up even when
single pixels are ambiguous. Trees are evaluated with a few integer comparisons per level,
which keeps the detector within a few ms per 320x240 image without a GPU.

Per image:

1. channels (luma, chroma, learned skin likelihood) and candidates (grid pixels whose skin
   likelihood passes the learned gate), :mod:`.channels`;
2. every candidate votes with every tree: weight :math:`w_\ell` (leaf tip probability) at
   the candidate plus the leaf's mean offset, :mod:`.forest`; leaves with
   :math:`w_\ell <` ``min_leaf_weight`` abstain (many weak votes from clutter only raise
   the floor of the vote image);
3. the vote image :math:`A` is smoothed with a Gaussian of ``smoothing_sigma_px``; local
   maxima over a disc of ``nms_radius_px`` (non-maximum suppression) whose height
   :math:`h` gives a score :math:`s = \min(1, h / h_0) \ge` ``min_score`` are the
   detections, where :math:`h_0` (``vote_norm``) is the median peak of a visible tip on
   the training views; the peak is refined to sub-pixel precision by the vote centroid in
   a 5 x 5 window.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from hand_tracker_ros._typing import Float32Array, FloatArray, UInt8Array
from hand_tracker_ros.config import param
from hand_tracker_ros.tracking.observations import SalientDetections
from hand_tracker_ros.vision.detector.channels import candidates, compute_channels
from hand_tracker_ros.vision.detector.forest import pack_nodes, vote
from hand_tracker_ros.vision.detector.model import DetectorModel
from hand_tracker_ros.vision.image import check_rgb

logger = logging.getLogger(__name__)

_REFINE_HALF = 2


@dataclass(frozen=True)
class DetectorConfig:
    """Fingertip detector."""

    model_path: str = param('', 'trained model (.npz); empty: the shipped model')
    min_score: float = param(0.4, 'minimum detection score', low=0.0, high=1.0)
    max_detections: int = param(5, 'keep at most this many detections (highest scores); 5 '
                                'per hand in view', low=0, high=100)
    nms_radius_px: float = param(5.0, 'radius of the non-maximum suppression disc',
                                 unit='px', low=1.0, high=50.0)
    smoothing_sigma_px: float = param(3.0, 'Gaussian smoothing of the vote image', unit='px',
                                      low=0.5, high=10.0)
    min_leaf_weight: float = param(0.2, 'leaves with a lower tip probability do not vote',
                                   low=0.0, high=1.0)


def smooth_votes(accumulator: Float32Array, sigma_px: float) -> Float32Array:
    """Gaussian-smoothed vote image (H, W) float32."""
    return cv2.GaussianBlur(accumulator, (0, 0), sigma_px, borderType=cv2.BORDER_CONSTANT)


def find_peaks(smoothed: Float32Array, min_height: float, nms_radius_px: float,
               max_peaks: int) -> tuple[FloatArray, FloatArray]:
    """Local maxima of a vote image.

    Parameters
    ----------
    smoothed : (H, W) float32
    min_height : float
        Peaks lower than this are dropped.
    nms_radius_px : float
        A peak must be the maximum of the disc of this radius around it.
    max_peaks : int

    Returns
    -------
    uv_px : (N, 2) float64
        Integer peak positions (u, v), highest first.
    height : (N,) float64
    """
    r = int(np.ceil(nms_radius_px))
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
    dilated = cv2.dilate(smoothed, kernel)
    vs, us = np.nonzero((smoothed >= dilated) & (smoothed >= max(min_height, 1e-6)))
    height = smoothed[vs, us].astype(np.float64)
    order = np.argsort(-height, kind='stable')[:max_peaks]
    return np.column_stack([us[order], vs[order]]).astype(np.float64), height[order]


def refine(accumulator: Float32Array, uv_px: FloatArray) -> FloatArray:
    """Vote centroid in a 5 x 5 window around each integer peak (N, 2) float64."""
    height, width = accumulator.shape
    out = uv_px.copy()
    for i, (u, v) in enumerate(uv_px.astype(np.int64)):
        u0, u1 = max(u - _REFINE_HALF, 0), min(u + _REFINE_HALF + 1, width)
        v0, v1 = max(v - _REFINE_HALF, 0), min(v + _REFINE_HALF + 1, height)
        window = accumulator[v0:v1, u0:u1].astype(np.float64)
        mass = window.sum()
        if mass > 0.0:
            gy, gx = np.mgrid[v0:v1, u0:u1]
            out[i] = ((gx * window).sum() / mass, (gy * window).sum() / mass)
    return out


class FingertipDetector:
    """Detect fingertip candidates in RGB images with a trained :class:`DetectorModel`.

    Parameters
    ----------
    model : DetectorModel
    config : DetectorConfig
    """

    def __init__(self, model: DetectorModel, config: DetectorConfig = DetectorConfig()) -> None:
        self.model = model
        self.config = config
        self._packed = pack_nodes(model.forest, model.bank)
        self._weight, self._offset = model.forest.votes(model.radius_px)

    @classmethod
    def load(cls, path: str | Path | None = None,
             config: DetectorConfig = DetectorConfig()) -> FingertipDetector:
        """Detector of the model at ``path``, else ``config.model_path``, else the shipped one."""
        path = path if path is not None else (config.model_path or None)
        return cls(DetectorModel.load(path), config)

    def votes(self, image_rgb: UInt8Array) -> Float32Array:
        """Raw vote image (H, W) float32 of one (H, W, 3) uint8 RGB image."""
        check_rgb('image_rgb', image_rgb)
        model = self.model
        channels = compute_channels(image_rgb, model.skin_lut)
        ys, xs = candidates(channels, model.stride, model.gate)
        accumulator = np.zeros(image_rgb.shape[:2], dtype=np.float32)
        vote(channels, ys, xs, model.forest.roots, self._packed, self._weight, self._offset,
             self.config.min_leaf_weight, accumulator)
        return accumulator

    def detect(self, image_rgb: UInt8Array) -> SalientDetections:
        """Fingertip candidates of one image.

        Parameters
        ----------
        image_rgb : (H, W, 3) uint8

        Returns
        -------
        SalientDetections
            ``uv_px`` (N, 2) float64 and ``score`` (N,) in [min_score, 1], highest first.

        Raises
        ------
        ImageFormatError
            ``image_rgb`` is not an (H, W, 3) uint8 array.
        """
        cfg = self.config
        accumulator = self.votes(image_rgb)
        smoothed = smooth_votes(accumulator, cfg.smoothing_sigma_px)
        uv, height = find_peaks(smoothed, cfg.min_score * self.model.vote_norm,
                                cfg.nms_radius_px, cfg.max_detections)
        score = np.minimum(height / self.model.vote_norm, 1.0)
        return SalientDetections(refine(accumulator, uv), score)
