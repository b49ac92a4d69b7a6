"""Foreground (hand) mask of one image, by one of three methods chosen by config.

- ``background``: a pixel is foreground where ``max_c |I_c - B_c| > threshold`` (per-channel
  absolute difference to a background frame ``B``). ``B`` is set explicitly or learned as the
  mean of the first ``learn_frames`` frames (the scene must be hand-free during them).
- ``skin``: a Gaussian skin-colour model in the (Cr, Cb) chroma plane of YCrCb, which is
  fairly independent of brightness. A pixel is foreground where its squared Mahalanobis
  distance ``d2 = (x - mu)^T S^-1 (x - mu)`` is at most ``skin_max_sigma^2``. The test is
  evaluated once for all 256 x 256 (Cr, Cb) pairs into a lookup table, so per frame it is a
  colour conversion and one gather. ``mu, S`` default to a generic skin cluster (Cr ~ 152,
  Cb ~ 108, about 3.3 sigma from gray (128, 128); Chai & Ngan 1999 report Cr in [133, 173],
  Cb in [77, 127]) or are fitted from sample pixels with :meth:`ForegroundMasker.fit_skin`.
- ``provided``: the caller supplies the mask image (e.g. a mask topic).

The background and skin masks are cleaned with a morphological opening (removes speckle)
then closing (fills small holes), elliptic kernel of ``morph_size_px``.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import cast

import cv2
import numpy as np

from hand_tracker_ros._typing import BoolArray, Float32Array, UInt8Array
from hand_tracker_ros.checks import check_shape
from hand_tracker_ros.config import param
from hand_tracker_ros.errors import ConfigError, ImageFormatError, ShapeError

logger = logging.getLogger(__name__)

MASK_METHODS = ('background', 'skin', 'provided')


@dataclass(frozen=True)
class MaskConfig:
    """Foreground (hand) mask."""

    method: str = param('skin', 'foreground mask method', choices=MASK_METHODS)
    background_threshold: float = param(
        25.0, 'background: per-channel absolute difference above which a pixel is '
        'foreground', unit='gray levels', low=0.0, high=255.0)
    learn_frames: int = param(5, 'background: frames averaged into the background when '
                              'none is set (0: it must be set explicitly)', low=0, high=1000)
    skin_cr_mean: float = param(152.0, 'skin: mean Cr of skin', low=0.0, high=255.0)
    skin_cb_mean: float = param(108.0, 'skin: mean Cb of skin', low=0.0, high=255.0)
    skin_cr_std: float = param(9.0, 'skin: standard deviation of Cr', low=0.5, high=128.0)
    skin_cb_std: float = param(10.0, 'skin: standard deviation of Cb', low=0.5, high=128.0)
    skin_cr_cb_corr: float = param(0.0, 'skin: Cr-Cb correlation coefficient', low=-0.99,
                                   high=0.99)
    skin_max_sigma: float = param(2.5, 'skin: Mahalanobis distance accepted as skin',
                                  low=0.1, high=10.0)
    morph_size_px: int = param(5, 'opening/closing kernel diameter; 0 disables the cleanup',
                               unit='px', low=0, high=51)


def skin_lut(mean_crcb: np.ndarray, cov_crcb: np.ndarray, max_sigma: float) -> Float32Array:
    """Skin test for every (Cr, Cb) pair.

    Parameters
    ----------
    mean_crcb : (2,) float64
        Mean (Cr, Cb).
    cov_crcb : (2, 2) float64
        Covariance, symmetric positive definite.
    max_sigma : float
        Accepted Mahalanobis distance.

    Returns
    -------
    lut : (256, 256) float32
        ``lut[cr, cb]`` is 255 for skin, else 0 (float32: the histogram type of
        ``cv2.calcBackProject``).
    """
    check_shape('mean_crcb', mean_crcb, (2,))
    check_shape('cov_crcb', cov_crcb, (2, 2))
    if not np.all(np.isfinite(cov_crcb)) or np.linalg.eigvalsh(cov_crcb)[0] <= 0.0:
        msg = f'skin covariance must be finite and positive definite, got {cov_crcb.tolist()}'
        raise ConfigError(msg)
    inv = np.linalg.inv(cov_crcb)
    levels = np.arange(256, dtype=np.float64)
    dcr = levels[:, None] - mean_crcb[0]
    dcb = levels[None, :] - mean_crcb[1]
    d2 = inv[0, 0] * dcr**2 + 2.0 * inv[0, 1] * dcr * dcb + inv[1, 1] * dcb**2
    return np.where(d2 <= max_sigma**2, 255.0, 0.0).astype(np.float32)


def _config_gaussian(config: MaskConfig) -> tuple[np.ndarray, np.ndarray]:
    mean = np.array([config.skin_cr_mean, config.skin_cb_mean])
    cross = config.skin_cr_cb_corr * config.skin_cr_std * config.skin_cb_std
    cov = np.array([[config.skin_cr_std**2, cross], [cross, config.skin_cb_std**2]])
    return mean, cov


class ForegroundMasker:
    """Stateful foreground mask of one camera (holds its background or skin model).

    Parameters
    ----------
    config : MaskConfig
    """

    def __init__(self, config: MaskConfig) -> None:
        self.config = config
        self._lut = skin_lut(*_config_gaussian(config), config.skin_max_sigma)
        self._background: UInt8Array | None = None
        self._accum: Float32Array | None = None
        self._n_accum = 0
        self._kernel = (cv2.getStructuringElement(
            cv2.MORPH_ELLIPSE, (config.morph_size_px, config.morph_size_px))
            if config.morph_size_px > 0 else None)

    @property
    def background(self) -> UInt8Array | None:
        """(H, W, 3) uint8 background frame, or None while not set/learned."""
        return self._background

    def set_background(self, image_rgb: UInt8Array) -> None:
        """Use ``image_rgb`` (H, W, 3) uint8 as the background frame."""
        self._background = np.array(image_rgb, dtype=np.uint8, copy=True)
        self._accum, self._n_accum = None, 0

    def reset(self) -> None:
        """Forget the background (it is learned again if ``learn_frames`` > 0)."""
        self._background, self._accum, self._n_accum = None, None, 0

    def fit_skin(self, samples_rgb: UInt8Array) -> None:
        """Fit the skin Gaussian to sample skin pixels.

        Parameters
        ----------
        samples_rgb : (N, 3) uint8
            RGB skin samples, N >= 3 and not all the same chroma.
        """
        check_shape('samples_rgb', samples_rgb, (None, 3))
        if samples_rgb.shape[0] < 3:
            msg = f'fit_skin needs at least 3 samples, got {samples_rgb.shape[0]}'
            raise ShapeError(msg)
        ycrcb = cv2.cvtColor(samples_rgb.astype(np.uint8).reshape(-1, 1, 3),
                             cv2.COLOR_RGB2YCrCb).reshape(-1, 3).astype(np.float64)
        crcb = ycrcb[:, 1:]
        # A small floor keeps the covariance invertible for near-uniform samples.
        cov = np.cov(crcb, rowvar=False) + np.eye(2) * 0.25
        self._lut = skin_lut(crcb.mean(axis=0), cov, self.config.skin_max_sigma)

    def compute(self, image_rgb: UInt8Array, provided: np.ndarray | None = None, *,
                roi_px: tuple[int, int, int, int] | None = None) -> BoolArray:
        """Foreground mask of one frame, optionally only in a region of interest.

        Parameters
        ----------
        image_rgb : (H, W, 3) uint8
            The whole frame (a background is learned from whole frames).
        provided : (H, W) bool or uint8, optional
            The mask image for method 'provided' (non-zero = foreground); ignored otherwise.
        roi_px : (u0, v0, u1, v1), optional
            Half-open box inside the image (see ``image.clip_roi``); None: the whole image.

        Returns
        -------
        mask : (v1 - v0, u1 - u0) bool
            The mask of the ROI. With method 'background', all False while the background
            is being learned.
        """
        u0, v0, u1, v1 = roi_px or (0, 0, image_rgb.shape[1], image_rgb.shape[0])
        method = self.config.method
        if method == 'provided':
            return _provided_mask(provided, image_rgb.shape[:2])[v0:v1, u0:u1]
        if method == 'skin':
            ycrcb = cv2.cvtColor(image_rgb[v0:v1, u0:u1], cv2.COLOR_RGB2YCrCb)
            # Back-projecting the LUT as a 2-D (Cr, Cb) histogram is the same gather as
            # lut[cr, cb], in C without the GIL: 0.1 ms instead of 0.35 ms at 320x240.
            raw = cast(UInt8Array, cv2.calcBackProject([ycrcb], [1, 2], self._lut,
                                                       [0, 256, 0, 256], 1.0))
        else:
            raw = self._background_difference(image_rgb, (u0, v0, u1, v1))
        return self._clean(raw) > 0

    def _background_difference(self, image_rgb: UInt8Array,
                               roi_px: tuple[int, int, int, int]) -> UInt8Array:
        u0, v0, u1, v1 = roi_px
        if self._background is not None and self._background.shape != image_rgb.shape:
            logger.info('image size changed to %s: relearning the background',
                        image_rgb.shape[:2])
            self.reset()
        if self._background is None:
            self._learn(image_rgb)
            return np.zeros((v1 - v0, u1 - u0), dtype=np.uint8)
        # cv2.max over the split channels: 0.1 ms at 320x240 vs 2 ms for ndarray.max(axis=2).
        red, green, blue = cv2.split(cv2.absdiff(image_rgb[v0:v1, u0:u1],
                                                 self._background[v0:v1, u0:u1]))
        diff = cv2.max(cv2.max(red, green), blue)
        _, raw = cv2.threshold(diff, self.config.background_threshold, 255, cv2.THRESH_BINARY)
        return cast(UInt8Array, raw)

    def _learn(self, image_rgb: UInt8Array) -> None:
        if self.config.learn_frames == 0:
            msg = ('mask method is background but no background frame was set and '
                   'learn_frames is 0')
            raise ConfigError(msg)
        if self._accum is None or self._accum.shape != image_rgb.shape:
            self._accum, self._n_accum = np.zeros(image_rgb.shape, dtype=np.float32), 0
        cv2.accumulate(image_rgb, self._accum)
        self._n_accum += 1
        if self._n_accum >= self.config.learn_frames:
            self._background = np.rint(self._accum / self._n_accum).astype(np.uint8)
            self._accum, self._n_accum = None, 0

    def _clean(self, raw: UInt8Array) -> UInt8Array:
        if self._kernel is None:
            return raw
        opened = cv2.morphologyEx(raw, cv2.MORPH_OPEN, self._kernel)
        return cast(UInt8Array, cv2.morphologyEx(opened, cv2.MORPH_CLOSE, self._kernel))


def _provided_mask(provided: np.ndarray | None, shape_hw: tuple[int, ...]) -> BoolArray:
    if provided is None:
        msg = 'mask method is provided but no mask image was given'
        raise ImageFormatError(msg)
    if provided.shape != tuple(shape_hw):
        msg = (f'provided mask has shape {tuple(provided.shape)} but the image is (H, W) = '
               f'{tuple(shape_hw)}')
        raise ImageFormatError(msg)
    return np.asarray(provided) != 0
