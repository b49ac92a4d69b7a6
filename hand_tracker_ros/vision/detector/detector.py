r"""Fingertip detection with a Hough forest: unlabelled tip candidates (u, v, score) per image.

Why a Hough forest (Gall & Lempitsky 2009; the detector family Ballan et al. 2012 used):
fingertips are small, have no texture of their own, and are defined by the *shape* of the
skin region around them, which pixel-pair tests over a window capture cheaply; the forest
combines classification ("is a tip within R px?") with a learned offset to the tip centre,
so every skin pixel near a tip votes for the same centre and the evidence adds up even when
single pixels are ambiguous. Trees are evaluated with a few integer comparisons per level,
which keeps the detector within a few ms per 320x240 image without a GPU. Vote height alone
cannot tell a tip from a knuckle or the wrist end (their peaks are as high), so a second,
small forest re-scores the few highest peaks from their surroundings, and a third one
re-scores them again knowing the scores of the other peaks of the image.

Per image:

1. channels (luma, chroma, learned skin likelihood) and candidates (grid pixels whose skin
   likelihood passes the learned gate), :mod:`.channels`;
2. every candidate votes with every tree: weight :math:`w_\ell` (leaf tip probability) at
   the candidate plus the leaf's mean offset, :mod:`.forest`; leaves with
   :math:`w_\ell <` ``min_leaf_weight`` abstain (many weak votes from clutter only raise
   the floor of the vote image);
3. the vote image :math:`A` is smoothed with a Gaussian of ``smoothing_sigma_px``; local
   maxima over a square of half-size ``nms_radius_px`` (non-maximum suppression) with
   height :math:`h \ge` ``peak_floor`` :math:`h_0` are peaks, at most ``max_peaks``
   highest, where :math:`h_0` (``vote_norm``) is the median peak of a visible tip on the
   training views; each peak is refined to sub-pixel precision by the vote centroid in a
   5 x 5 window of :math:`A`;
4. the verifier forest maps each peak's features (:mod:`.verifier`: vote height, rank,
   ring profiles of skin, gate mask and luma, :mod:`.shape` terms) to a tip probability
   :math:`s_1`; the context verifier (boosted trees) maps the same features plus the
   context of all :math:`s_1` of the image (:func:`.verifier.context_features`) to a logit
   :math:`z` and the tip probability :math:`s = 1 / (1 + e^{-z})`; peaks with
   :math:`s \ge` ``min_score`` are the detections, at most ``max_detections``, highest
   :math:`s` first.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import cv2
import numba
import numpy as np

from hand_tracker_ros._typing import BoolArray, Float32Array, FloatArray, IntArray, UInt8Array
from hand_tracker_ros.config import param
from hand_tracker_ros.tracking.observations import SalientDetections
from hand_tracker_ros.vision.detector.channels import candidates, compute_channels, gate_image
from hand_tracker_ros.vision.detector.forest import pack_nodes, predict, vote
from hand_tracker_ros.vision.detector.model import DetectorModel
from hand_tracker_ros.vision.detector.verifier import context_features, peak_features
from hand_tracker_ros.vision.image import check_rgb

logger = logging.getLogger(__name__)

_REFINE_HALF = 2


@dataclass(frozen=True)
class DetectorConfig:
    """Fingertip detector."""

    model_path: str = param('', 'trained model (.npz); empty: the shipped model')
    min_score: float = param(0.4, 'minimum detection score (verifier tip probability)',
                             low=0.0, high=1.0)
    max_detections: int = param(5, 'keep at most this many detections (highest scores); 5 '
                                'per hand in view', low=0, high=100)
    nms_radius_px: float = param(5.0, 'half-size of the non-maximum suppression square',
                                 unit='px', low=1.0, high=50.0)
    smoothing_sigma_px: float = param(3.0, 'Gaussian smoothing of the vote image', unit='px',
                                      low=0.5, high=10.0)
    min_leaf_weight: float = param(0.2, 'leaves with a lower tip probability do not vote',
                                   low=0.0, high=1.0)


def smoothing_radius_px(sigma_px: float) -> int:
    """Half-size of the Gaussian kernel of :func:`smooth_votes`: OpenCV's choice for float
    images, a kernel of ``round(8 sigma + 1) | 1`` taps."""
    return (int(round(8.0 * sigma_px + 1.0)) | 1) // 2


def smooth_votes(accumulator: Float32Array, sigma_px: float) -> Float32Array:
    """Gaussian-smoothed vote image (H, W) float32 (zero outside the image)."""
    size = 2 * smoothing_radius_px(sigma_px) + 1
    return cv2.GaussianBlur(accumulator, (size, size), sigma_px,
                            borderType=cv2.BORDER_CONSTANT)


def vote_box(ys: IntArray, xs: IntArray, margin_px: int,
             shape_hw: tuple[int, int]) -> tuple[slice, slice]:
    """Rows and columns within ``margin_px`` of the candidates ``ys, xs`` (N,) int, clipped
    to the image (without candidates, the vote-free 1 x 1 box at the origin)."""
    if ys.size == 0:
        return slice(0, 1), slice(0, 1)
    return (slice(max(int(ys.min()) - margin_px, 0), min(int(ys.max()) + margin_px + 1,
                                                         shape_hw[0])),
            slice(max(int(xs.min()) - margin_px, 0), min(int(xs.max()) + margin_px + 1,
                                                         shape_hw[1])))


def find_peaks(smoothed: Float32Array, min_height: float, nms_radius_px: float,
               max_peaks: int) -> tuple[FloatArray, FloatArray]:
    """Local maxima of a vote image.

    Parameters
    ----------
    smoothed : (H, W) float32
    min_height : float
        Peaks lower than this are dropped.
    nms_radius_px : float
        A peak must be the maximum of the square of half-size ``ceil(nms_radius_px)``
        around it (a square, not a disc: a rectangular dilation is separable, ~5x faster).
    max_peaks : int

    Returns
    -------
    uv_px : (N, 2) float64
        Integer peak positions (u, v), highest first.
    height : (N,) float64
    """
    size = 2 * int(np.ceil(nms_radius_px)) + 1
    dilated = cv2.dilate(smoothed, np.ones((size, size), np.uint8))
    vs, us = np.nonzero((smoothed >= dilated) & (smoothed >= max(min_height, 1e-6)))
    height = smoothed[vs, us].astype(np.float64)
    order = np.argsort(-height, kind='stable')[:max_peaks]
    return np.column_stack([us[order], vs[order]]).astype(np.float64), height[order]


@numba.njit(cache=True, nogil=True)
def refine(accumulator: Float32Array, uv_px: FloatArray) -> FloatArray:
    """Vote centroid in a 5 x 5 window around each integer peak (N, 2) float64.

    A numba loop: per-peak numpy windows cost ~0.1 ms of interpreter overhead each.
    """
    height, width = accumulator.shape
    out = uv_px.copy()
    for i in range(uv_px.shape[0]):
        u, v = int(uv_px[i, 0]), int(uv_px[i, 1])
        mass, mu, mv = 0.0, 0.0, 0.0
        for y in range(max(v - _REFINE_HALF, 0), min(v + _REFINE_HALF + 1, height)):
            for x in range(max(u - _REFINE_HALF, 0), min(u + _REFINE_HALF + 1, width)):
                a = float(accumulator[y, x])
                mass += a
                mu += a * x
                mv += a * y
        if mass > 0.0:
            out[i, 0], out[i, 1] = mu / mass, mv / mass
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
        # Votes land within `reach` px of their candidate and smoothing spreads them by the
        # kernel radius: smoothing and peak search beyond that box would only see zeros.
        voting = self._weight >= config.min_leaf_weight
        reach = int(np.ceil(np.abs(self._offset[voting]).max(initial=0.0)))
        self._margin_px = reach + smoothing_radius_px(config.smoothing_sigma_px)
        self._verifier_nodes = model.verifier.nodes()
        self._context_nodes = model.context.nodes()

    @classmethod
    def load(cls, path: str | Path | None = None,
             config: DetectorConfig = DetectorConfig()) -> FingertipDetector:
        """Detector of the model at ``path``, else ``config.model_path``, else the shipped one."""
        path = path if path is not None else (config.model_path or None)
        return cls(DetectorModel.load(path), config)

    def votes(self, image_rgb: UInt8Array) -> Float32Array:
        """Raw vote image (H, W) float32 of one (H, W, 3) uint8 RGB image."""
        return self._vote(image_rgb)[2]

    def _vote(self, image_rgb: UInt8Array
              ) -> tuple[UInt8Array, BoolArray, Float32Array, tuple[slice, slice]]:
        """Channels (C, H, W) uint8, gate mask (H, W) bool, raw votes (H, W) float32 and the
        box outside which the smoothed votes are zero (:func:`vote_box`)."""
        check_rgb('image_rgb', image_rgb)
        model = self.model
        channels = compute_channels(image_rgb, model.skin_lut)
        gate_mask = gate_image(channels) >= model.gate
        ys, xs = candidates(gate_mask, model.stride)
        accumulator = np.zeros(image_rgb.shape[:2], dtype=np.float32)
        vote(channels, ys, xs, model.forest.roots, self._packed, self._weight, self._offset,
             self.config.min_leaf_weight, accumulator)
        box = vote_box(ys, xs, self._margin_px, accumulator.shape)
        return channels, gate_mask, accumulator, box

    def peaks(self, image_rgb: UInt8Array) -> tuple[FloatArray, Float32Array]:
        """Refined vote peaks and their verifier features (steps 1-4 of the module docstring).

        Returns
        -------
        uv_px : (N, 2) float64
            At most ``max_peaks`` peaks, highest vote first.
        features : (N, verifier.N_FEATURES) float32
        """
        model = self.model
        channels, gate_mask, accumulator, (rows, cols) = self._vote(image_rgb)
        # Smoothing and peaks in the vote box only: the same values and peaks as on the
        # whole image (outside it the smoothed votes are 0; a dilation that also saw those
        # zeros would not change a maximum of non-negative votes).
        smoothed = smooth_votes(accumulator[rows, cols], self.config.smoothing_sigma_px)
        uv, height = find_peaks(smoothed, model.peak_floor * model.vote_norm,
                                self.config.nms_radius_px, model.max_peaks)
        uv = refine(accumulator, uv + np.array([cols.start, rows.start], dtype=np.float64))
        return uv, peak_features(uv, height, channels, gate_mask, model.vote_norm)

    def scores(self, uv_px: FloatArray, features: Float32Array) -> FloatArray:
        """Tip probability (N,) float64 of the peaks ``uv_px`` (N, 2) of one image (step 4)."""
        first = predict(self._verifier_nodes, features)[:, 0]
        both = np.concatenate([features, context_features(uv_px, first)], axis=1)
        return 1.0 / (1.0 + np.exp(-predict(self._context_nodes, both)[:, 0]))

    def detect(self, image_rgb: UInt8Array) -> SalientDetections:
        """Fingertip candidates of one image.

        Parameters
        ----------
        image_rgb : (H, W, 3) uint8

        Returns
        -------
        SalientDetections
            ``uv_px`` (N, 2) float64 and ``score`` (N,) in [min_score, 1] (the verifier's
            tip probability), highest first.

        Raises
        ------
        ImageFormatError
            ``image_rgb`` is not an (H, W, 3) uint8 array.
        """
        cfg = self.config
        uv, features = self.peaks(image_rgb)
        score = self.scores(uv, features)
        keep = np.flatnonzero(score >= cfg.min_score)
        keep = keep[np.argsort(-score[keep], kind='stable')][:cfg.max_detections]
        return SalientDetections(uv[keep], np.minimum(score[keep], 1.0))
