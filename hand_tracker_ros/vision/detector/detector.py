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

References: docs/references.md.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from hand_tracker_ros._typing import Float32Array, FloatArray, UInt8Array
from hand_tracker_ros.checks import check_rgb
from hand_tracker_ros.config import param
from hand_tracker_ros.vision.detections import SalientDetections
from hand_tracker_ros.vision.detector.model import STRIDE, DetectorModel

_NMS_KERNEL = np.ones((3, 3), np.uint8)


@dataclass(frozen=True)
class DetectorConfig:
    """Fingertip detector."""

    model_path: str = param('', 'trained model (.onnx); empty: the shipped model')
    min_score: float = param(0.4, 'minimum detection score (tip probability of the network)',
                             low=0.0, high=1.0)
    max_detections: int = param(5, 'keep at most this many detections (highest scores); 5 '
                                'per hand in view', low=0, high=100)
    threads: int = param(1, 'ONNX Runtime threads per detector', low=1, high=64)


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

    def detect(self, image_rgb: UInt8Array) -> SalientDetections:
        """Fingertip candidates of one image.

        Parameters
        ----------
        image_rgb : (H, W, 3) uint8

        Returns
        -------
        SalientDetections
            ``uv_px`` (N, 2) float64 and ``score`` (N,) in [min_score, 1] (the network's tip
            probability), highest first.

        Raises
        ------
        ImageFormatError
            ``image_rgb`` is not an (H, W, 3) uint8 array.
        """
        uv, score = find_peaks(self.maps(image_rgb), self.config.min_score,
                               self.config.max_detections)
        return SalientDetections(uv, score)
