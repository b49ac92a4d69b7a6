r"""Fingertip detection with a small fully convolutional network: unlabelled tip candidates
(u, v, score) per image.

The network (:mod:`.network`, trained by :mod:`.training`) is CenterNet-style (Zhou et al.
2019, "Objects as points"): at 1/4 resolution it predicts for every cell the probability
:math:`p` that a visible fingertip lies there and the tip's sub-cell offset. This is the
modern form of the Hough voting of the previous detector (Gall & Lempitsky 2009; the
detector family Ballan et al. 2012 used): a dense tip likelihood where a Hough forest
accumulated votes, and a regressed offset to the tip centre where each forest leaf cast its
vote with a learned offset. Unlike the forest, whose pixel-pair tests and hand-designed
verifier features limited it (precision 0.856 / recall 0.754 on the bench), the network
learns its features and sees 151 px of context, enough to tell a fingertip from a knuckle
or the wrist end of the silhouette.

Per image (:class:`.model.DetectorModel` runs the network with ONNX Runtime, no PyTorch):

1. maps :math:`p` and :math:`(\delta_u, \delta_v)`, (ceil(H/4), ceil(W/4)) each;
2. peaks: cells that are the maximum of their 3 x 3 neighbourhood (non-maximum suppression
   by max pooling, as in CenterNet) with :math:`p \ge` ``min_score``;
3. a peak at cell (i, j) is the detection :math:`(u, v) = 4\,(j + \delta_u, i + \delta_v)`
   with score :math:`p`; at most ``max_detections``, highest score first.

Scale. One level of the network finds hands up to about ``max_hand_px`` (bounding-box
side). The renders it is trained on have hands of 68-155 px (5th-95th percentile, at
320 x 240), and the scale augmentation of :mod:`.augment` widens that to about 40-280 px,
hands under 40 px being trained as negatives; but on the validation views (seed 1) enlarged
1-3x and run at one level, recall stays at 0.79-0.82 only for hands up to 180 px (0.68 at
180-210 px, 0.47 at 240-280 px), hence 180. A hand close to the camera can fill the image,
so :meth:`FingertipDetector.detect` runs an image pyramid: level :math:`k` is the image
shrunk by :math:`2^k` (area averaging), and levels are added while the previous one's
short side exceeds ``max_hand_px`` (at most ``max_levels``): two levels at 320 x 240, three
at 640 x 480. One level's detections are kept. Its *strength* is the sum of its
``max_detections`` highest peaks of :math:`p` (:func:`level_strength`); going from fine to
coarse, a level replaces the kept one when it is stronger by more than ``coarser_margin``
(0.1): scale selection by the strongest response over scales (Lindeberg 1998), with a
preference for the finer level. A hand at the size the network knows gives confident peaks,
the same hand far larger or smaller weak ones.

Chosen on the validation views at ``min_score`` 0.45, enlarged 1x, 1.5x, 2x, 2.5x and 3x
(precision / recall, with the twelfth session's model of ``training.py``'s log): 0.909 /
0.811, 0.909 / 0.816, 0.909 / 0.827, 0.893 / 0.818, 0.893 / 0.801. The detections of all
levels merged instead (until 2026-11-27, with ``max_hand_px`` 300) let a coarser level's
false positives displace a finer level's tips: 0.914 / 0.808, 0.894 / 0.832, 0.900 / 0.840,
0.892 / 0.822, 0.847 / 0.841. Without the margin, 0.897 / 0.812, 0.910 / 0.821, 0.900 /
0.821, 0.895 / 0.826, 0.898 / 0.814: better at 1.5x, 2.5x and 3x, but below precision 0.9 at
1x, the working resolution; with 0.2, recall 0.795 and 0.768 at 2.5x and 3x. Detections are
mapped back to full-resolution pixels. One level per image serves one hand size: two hands
at very different distances are not both at their best level.

Region of interest. With ``roi_px`` (the tracker's box around its estimate,
:mod:`hand_tracker_ros.tracking.roi`) only that box is searched, at one level, shrunk (if
needed) so that its long side is at most ``roi_max_px``, at most at the cost of a 300
px-square image. The box is the hand grown by half its size on every side plus a margin
(about 2h + 49 px for a hand of h px), so a shrunk hand stays under 150 px; but the box is
clipped to the image, and at 320 x 240 a hand of over about 180 px reaches the network
beyond the size one level finds reliably (shrinking every box to 180 px instead slowed the
live tracker; training.py's log).

References: docs/references.md.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import cast

import cv2
import numpy as np

from hand_tracker_ros._typing import Float32Array, FloatArray, UInt8Array
from hand_tracker_ros.checks import check_rgb
from hand_tracker_ros.config import param
from hand_tracker_ros.vision.detections import SalientDetections
from hand_tracker_ros.vision.detector.model import STRIDE, DetectorModel
from hand_tracker_ros.vision.image import Box

_NMS_KERNEL = np.ones((3, 3), np.uint8)


@dataclass(frozen=True)
class DetectorConfig:
    """Fingertip detector."""

    model_path: str = param('', 'trained model (.onnx); empty: the shipped model')
    min_score: float = param(0.45, 'minimum detection score (tip probability of the '
                             'network); the lowest on a 0.05 grid with precision 0.9 on the '
                             'validation views (training.py log)', low=0.0, high=1.0)
    max_detections: int = param(5, 'keep at most this many detections (highest scores); 5 '
                                'per hand in view', low=0, high=100)
    threads: int = param(1, 'ONNX Runtime threads per detector', low=1, high=64)
    max_hand_px: float = param(180.0, 'largest hand (bounding-box side) one pyramid level '
                               'finds; coarser levels are added while the image is larger',
                               unit='px', low=16.0, high=10000.0)
    max_levels: int = param(3, 'most pyramid levels (octaves); 1: full resolution only',
                            low=1, high=8)
    roi_max_px: float = param(300.0, 'a region of interest is shrunk to at most this long '
                              'side (it holds the hand and the tracker\'s margin)', unit='px',
                              low=16.0, high=10000.0)
    coarser_margin: float = param(0.1, 'a coarser pyramid level replaces the kept one when its '
                                  'strength is larger by more than this fraction', low=0.0,
                                  high=10.0)


def find_peaks(maps: Float32Array, min_score: float, max_peaks: int
               ) -> tuple[FloatArray, FloatArray]:
    """Detections from the network's maps (steps 2-3 of the module docstring).

    Parameters
    ----------
    maps : (3, h, w) float32
        Tip probability and offset (du, dv) in cells.
    min_score : float
    max_peaks : int

    Returns
    -------
    uv_px : (N, 2) float64
        Tip positions (u, v), highest score first.
    score : (N,) float64
    """
    prob = maps[0]
    peak = (prob >= cv2.dilate(prob, _NMS_KERNEL)) & (prob >= min_score)
    rows, cols = np.nonzero(peak)
    score = prob[rows, cols].astype(np.float64)
    order = np.argsort(-score, kind='stable')[:max_peaks]
    rows, cols = rows[order], cols[order]
    uv = STRIDE * np.column_stack([cols + maps[1, rows, cols], rows + maps[2, rows, cols]])
    return uv.astype(np.float64), score[order]


def pyramid_levels(shape_hw: tuple[int, ...], max_hand_px: float, max_levels: int) -> int:
    """Number of pyramid levels of an (H, W) image: octaves are added while the previous
    level's short side exceeds ``max_hand_px`` (module docstring), at most ``max_levels``."""
    levels, short = 1, float(min(shape_hw[0], shape_hw[1]))
    while levels < max_levels and short > max_hand_px:
        levels, short = levels + 1, short / 2.0
    return levels


def level_strength(maps: Float32Array, max_peaks: int) -> float:
    """Strength of one pyramid level: the sum of the ``max_peaks`` highest peak
    probabilities of its maps (3, h, w), by which :meth:`FingertipDetector.detect` chooses
    the level it keeps (module docstring)."""
    return float(find_peaks(maps, 0.0, max_peaks)[1].sum())


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

    @classmethod
    def load(cls, path: str | Path | None = None,
             config: DetectorConfig = DetectorConfig()) -> FingertipDetector:
        """Detector of the model at ``path``, else ``config.model_path``, else the shipped one."""
        path = path if path is not None else (config.model_path or None)
        return cls(DetectorModel.load(path, config.threads), config)

    def maps(self, image_rgb: UInt8Array) -> Float32Array:
        """The network's tip probability and offset maps (3, ceil(H/4), ceil(W/4)) float32
        of one (H, W, 3) uint8 RGB image."""
        check_rgb('image_rgb', image_rgb)
        return self.model.maps(np.ascontiguousarray(image_rgb))

    def detect(self, image_rgb: UInt8Array, roi_px: Box | None = None) -> SalientDetections:
        """Fingertip candidates of one image (the pyramid, or the ``roi_px`` box).

        Parameters
        ----------
        image_rgb : (H, W, 3) uint8
        roi_px : (u0, v0, u1, v1), optional
            Half-open box (px) to search instead of the whole image (clipped to it).

        Returns
        -------
        SalientDetections
            ``uv_px`` (N, 2) float64 (full-image pixels) and ``score`` (N,) in [min_score, 1]
            (the network's tip probability), highest first.

        Raises
        ------
        ImageFormatError
            ``image_rgb`` is not an (H, W, 3) uint8 array.
        """
        check_rgb('image_rgb', image_rgb)
        if roi_px is not None:
            return self._detect_in_roi(image_rgb, roi_px)
        cfg = self.config
        levels = [self._level(image_rgb, k) for k in
                  range(pyramid_levels(image_rgb.shape[:2], cfg.max_hand_px, cfg.max_levels))]
        strength, maps, factor = levels[0]
        for coarser in levels[1:]:
            if coarser[0] > (1.0 + cfg.coarser_margin) * strength:
                strength, maps, factor = coarser
        uv, score = find_peaks(maps, cfg.min_score, cfg.max_detections)
        # Pixel centres are integers at every level: u_full + 0.5 = f (u_small + 0.5).
        return SalientDetections((uv + 0.5) * factor - 0.5, score)

    def _level(self, image_rgb: UInt8Array, k: int
               ) -> tuple[float, Float32Array, FloatArray]:
        """Pyramid level ``k`` of an image: its :func:`level_strength`, maps (3, h, w) and
        the factor (2,) from its pixels to full-resolution ones."""
        height, width = image_rgb.shape[:2]
        size = (-(-width // 2 ** k), -(-height // 2 ** k))
        level = image_rgb if k == 0 else cv2.resize(image_rgb, size,
                                                    interpolation=cv2.INTER_AREA)
        maps = self.model.maps(np.ascontiguousarray(level))
        return (level_strength(maps, self.config.max_detections), maps,
                np.array([width / size[0], height / size[1]]))

    def _detect_in_roi(self, image_rgb: UInt8Array, roi_px: Box) -> SalientDetections:
        """Detections in the box ``roi_px`` (module docstring), in full-image pixels."""
        height, width = image_rgb.shape[:2]
        u0, v0 = max(int(roi_px[0]), 0), max(int(roi_px[1]), 0)
        u1, v1 = min(int(roi_px[2]), width), min(int(roi_px[3]), height)
        if u1 - u0 < STRIDE or v1 - v0 < STRIDE:
            return SalientDetections.empty()
        crop = image_rgb[v0:v1, u0:u1]
        shrink = min(1.0, self.config.roi_max_px / max(u1 - u0, v1 - v0))
        size = (max(round((u1 - u0) * shrink), 1), max(round((v1 - v0) * shrink), 1))
        if shrink < 1.0:
            crop = cast(UInt8Array, cv2.resize(crop, size, interpolation=cv2.INTER_AREA))
        uv, score = find_peaks(self.model.maps(np.ascontiguousarray(crop)),
                               self.config.min_score, self.config.max_detections)
        factor = np.array([(u1 - u0) / size[0], (v1 - v0) / size[1]])
        return SalientDetections((uv + 0.5) * factor - 0.5 + (u0, v0), score)
