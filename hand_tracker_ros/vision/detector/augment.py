r"""Training-time augmentation of the rendered views: skin tone, background, scale, lighting.

The renders (:mod:`.data`) have one skin tone (a light one, +-8 % per channel), textured
synthetic backgrounds and hands of one size range (68-155 px, 5th-95th percentile of the
bounding-box side, at 320 x 240). A network trained on them alone found none of five tips on
real photos at their native scale and none on a darker hand. The training views are rendered
with skin creases (:mod:`.creases`, ``crease_depth``), and each then goes through, in order
(every draw from the training ``rng``):

1. skin tone (:func:`recolour_skin`): with probability ``skin_probability`` the hand pixels
   (the render's mask) are multiplied per channel by :math:`g = (d / b)^t`,
   :math:`t \sim U(0, 1)`, with :math:`b` the renders' base skin albedo and :math:`d`
   ``dark_skin_rgb``: a geometric walk from the base tone to a dark brown. Shading is albedo
   times light, so scaling the shaded pixels is the render with another albedo (up to the
   noise added after shading);
2. background (:func:`plain_background`): with probability ``plain_background_probability``
   the non-hand pixels become a plain surface (a random gray-ish colour, a linear gradient
   and weak noise), which the renders' noise / stripes / blobs backgrounds never are;
3. fine texture (:func:`fine_texture`): with probability ``texture_probability`` a
   zero-mean texture of 1-6 px grain (:math:`a\,t`, :math:`a \sim U(5, 35)` gray levels,
   sometimes stretched along one axis as in fabric or wood) and with probability 0.5 up to
   three straight lines (tile seams, table edges) are added to the non-hand pixels, and a
   weaker texture of its own multiplies the hand pixels by
   :math:`1 + b\,t`, :math:`b \sim U(0, 0.08)` (mottled skin, pores, pads). The renders'
   backgrounds vary over 13 px and more, and their skin is smooth; on a photo of a hand
   before a speckled ceiling tile (Back_Projection_Theory0.jpg of the real-photo bench) the
   network found no tip until that background was blurred. That photo showed what was
   missing; the ranges are not fitted to it;
4. flips left-right and up-down (probability 0.5 each);
5. scale and crop (:func:`scaled_crop`): the crop window of the source is
   ``crop / s`` px, :math:`\log s \sim U(\log s_0, \log s_1)` (``scale_range``), resampled to
   the crop size; the window is centred on the tips' mean plus a uniform shift of a third of
   the window (probability ``hand_crop_fraction``), else anywhere, and moved inside the view
   where it fits (else centred, the border replicated: a reflected border would show
   unlabelled mirror hands). Shrinking first low-passes the view (Gaussian,
   :math:`\sigma = 0.5 \sqrt{1/s^2 - 1}` px) against aliasing;
6. lighting and camera (:func:`photometric`): contrast, brightness, gamma, per-channel
   gains (white balance), with probability 0.5 a Gaussian blur and with probability 0.3 a
   JPEG round trip;
7. hand size (:func:`size_labels`, scale selection): with ``small_hand_px = (lo, hi)``, a
   crop whose hand (bounding-box side of the render's mask, times the scale) is smaller
   than ``lo`` keeps its tips only as negatives, and one from ``lo`` to ``hi`` has them
   ignored. The network then answers only for hands of at least ``lo``, so that the
   coarser levels of the pyramid (:mod:`.detector`) need not fire on the small hands of a
   finer one (SNIP's scale normalisation, Singh & Davis 2018, with negatives instead of
   ignored out-of-range objects at the small end). The pyramid only shrinks: a hand under
   ``lo`` at full resolution is not detected (the renders' hands are 68-155 px, 5th-95th
   percentile, at 320 x 240).

Ranges are ours, chosen on principle rather than on any test image. Scale 0.4-1.8 (hands of
about 27-280 px from the renders' 68-155 px, 5th-95th percentile of the bounding-box side at
320 x 240) was meant to span what one level of the detector's image pyramid could hold
when a level was added only while the image's short side exceeded 300 px: small and distant
hands at full resolution, and hands up to most of a 320 x 240 view. One level proved
reliable up to 180 px only, which the pyramid now uses (:mod:`.detector`). Hands under
40 px are negatives and 40-55 px ignored (step 7), because a 2-3 px finger is no longer a
fingertip's shape.
The earlier ranges, 0.5-2 and 0.7-1.4 without size classes, and the runs since are in
``training.py``'s log. The dark tone is about the darkest of
common skin-tone palettes; the lighting ranges are those of indoor webcams.

References: docs/references.md.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import cv2
import numpy as np

from hand_tracker_ros._typing import BoolArray, Float32Array, FloatArray, UInt8Array
from hand_tracker_ros.config import param

# The renders' base skin albedo (data._BASE_SKIN).
BASE_SKIN_RGB = np.array([224.0, 172.0, 145.0])


@dataclass(frozen=True)
class AugmentationConfig:
    """Augmentation of the training views (module docstring)."""

    scale_range: tuple = param((0.4, 1.8), 'range of the scale factor s of the crops '
                               '(log-uniform)', low=0.05, high=20.0)
    skin_probability: float = param(0.7, 'probability of a recoloured skin tone', low=0.0,
                                    high=1.0)
    dark_skin_rgb: tuple = param((88.0, 58.0, 42.0), 'darkest skin albedo of the walk from '
                                 'the base tone', low=0.0, high=255.0)
    plain_background_probability: float = param(0.2, 'probability of a plain background',
                                                 low=0.0, high=1.0)
    texture_probability: float = param(0.5, 'probability of a fine texture on the '
                                       'background (and a weaker one on the skin)',
                                       low=0.0, high=1.0)
    photometric: bool = param(True, 'contrast, brightness, gamma, white balance, blur, JPEG')
    crease_depth: tuple = param((0.0, 0.5), 'range of the darkening of the skin creases '
                                '(:mod:`.creases`), drawn per training view when it is '
                                'rendered; (0, 0): none', low=0.0, high=1.0)
    small_hand_px: tuple = param((40.0, 55.0), 'hands smaller than the first (bounding-box side '
                                 'in the crop) are negatives, up to the second ignored; '
                                 '(0, 0): every hand is a positive', unit='px', low=0.0,
                                 high=10000.0)


def recolour_skin(image: UInt8Array, mask: BoolArray, gain: FloatArray) -> UInt8Array:
    """``image`` with the ``mask`` pixels multiplied by ``gain`` (3,) (step 1)."""
    out = image.copy()
    out[mask] = np.clip(image[mask] * gain, 0.0, 255.0).astype(np.uint8)
    return out


def skin_gain(rng: np.random.Generator, cfg: AugmentationConfig) -> FloatArray:
    """Per-channel gain (3,) from the base to a random tone of the walk (step 1)."""
    ratio = np.asarray(cfg.dark_skin_rgb, dtype=np.float64) / BASE_SKIN_RGB
    return ratio ** rng.uniform(0.0, 1.0)


def plain_background(image: UInt8Array, mask: BoolArray, rng: np.random.Generator
                     ) -> UInt8Array:
    """``image`` with the non-``mask`` pixels replaced by a plain surface (step 2)."""
    height, width = mask.shape
    colour = rng.uniform(40.0, 235.0) + rng.uniform(-15.0, 15.0, 3)
    # A linear gradient of up to +-40 gray levels across the view, as under one lamp.
    slope = rng.uniform(-40.0, 40.0, 2) / np.array([width, height])
    v, u = np.mgrid[0:height, 0:width]
    ramp = (u - width / 2.0) * slope[0] + (v - height / 2.0) * slope[1]
    surface = colour + ramp[..., None] + rng.normal(0.0, rng.uniform(0.0, 4.0), image.shape)
    surface = np.clip(surface, 0.0, 255.0).astype(np.uint8)
    return np.where(mask[..., None], image, surface)


def fine_texture(shape_hw: tuple[int, int], rng: np.random.Generator) -> Float32Array:
    r"""A random texture (H, W) float32, zero mean and unit standard deviation (step 3).

    Two octaves of value noise (uniform random grids upsampled bicubically, the coarser one
    at half weight) with a grain of :math:`g \sim` log-U(1, 6) px, stretched with
    probability 0.3 by up to 3x along one image axis (and shrunk along the other).
    """
    height, width = shape_hw
    grain = np.exp(rng.uniform(0.0, np.log(6.0)))
    stretch = np.exp(rng.uniform(-np.log(3.0), np.log(3.0))) if rng.random() < 0.3 else 1.0
    texture = np.zeros((height, width), np.float32)
    for octave, weight in ((1.0, 1.0), (2.0, 0.5)):
        cell_u, cell_v = grain * octave * stretch, grain * octave / stretch
        grid = rng.random((int(height / cell_v) + 2, int(width / cell_u) + 2), np.float32)
        texture += np.float32(weight) * cv2.resize(grid, (width, height),
                                                   interpolation=cv2.INTER_CUBIC)
    mean, std = cv2.meanStdDev(texture)
    return (texture - np.float32(mean[0, 0])) / np.float32(max(std[0, 0], 1e-9))


def textured(image: UInt8Array, mask: BoolArray, rng: np.random.Generator) -> UInt8Array:
    """``image`` with a fine texture and lines added to its background and a weaker texture
    multiplying its ``mask`` (hand) pixels (step 3)."""
    height, width = mask.shape
    background = np.float32(rng.uniform(5.0, 35.0)) * fine_texture((height, width), rng)
    if rng.random() < 0.5:
        lines = np.zeros((height, width), np.float32)
        for _ in range(int(rng.integers(1, 4))):
            centre, angle = rng.uniform((0.0, 0.0), (width, height)), rng.uniform(0.0, np.pi)
            reach = (width + height) * np.array([np.cos(angle), np.sin(angle)])
            ends = np.rint([centre - reach, centre + reach]).astype(int)
            cv2.line(lines, tuple(ends[0]), tuple(ends[1]), float(rng.choice((-1, 1)))
                     * rng.uniform(20.0, 60.0), int(rng.integers(1, 5)))
        background += lines
    skin = 1.0 + np.float32(rng.uniform(0.0, 0.08)) * fine_texture((height, width), rng)
    gain = np.where(mask, skin, np.float32(1.0))[..., None]
    offset = np.where(mask, np.float32(0.0), background)[..., None]
    return np.clip(image * gain + offset, 0.0, 255.0).astype(np.uint8)


def scaled_crop(image: UInt8Array, uv_px: FloatArray, scale: float, origin_px: FloatArray,
                crop_hw: tuple[int, int]) -> tuple[UInt8Array, FloatArray]:
    """The crop whose pixel (u, v) is the source point ``origin + (u, v) / scale`` (step 5).

    Parameters
    ----------
    image : (H, W, 3) uint8
    uv_px : (5, 2) float64
        Tips in ``image`` (NaN allowed).
    scale : float
        Crop pixels per source pixel.
    origin_px : (2,) float64
        Source point (u, v) that lands on crop pixel (0, 0).
    crop_hw : (int, int)

    Returns
    -------
    crop : (crop_h, crop_w, 3) uint8
    uv_px : (5, 2) float64
        ``scale * (uv_px - origin_px)``.
    """
    if scale < 1.0:
        sigma = 0.5 * np.sqrt(1.0 / scale ** 2 - 1.0)
        image = cast(UInt8Array, cv2.GaussianBlur(image, (0, 0), sigma))
    # Pixel centres are integers: crop pixel x samples the source at origin + x / scale.
    affine = np.array([[scale, 0.0, -scale * origin_px[0]],
                       [0.0, scale, -scale * origin_px[1]]])
    crop = cast(UInt8Array, cv2.warpAffine(image, affine, (crop_hw[1], crop_hw[0]),
                                           flags=cv2.INTER_LINEAR,
                                           borderMode=cv2.BORDER_REPLICATE))
    return crop, scale * (uv_px - origin_px)


def hand_size_px(mask: BoolArray) -> float:
    """Bounding-box side (the longer one, px) of the ``mask`` (H, W) pixels; 0 if empty."""
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    if rows.size == 0:
        return 0.0
    return float(max(rows[-1] - rows[0], cols[-1] - cols[0]) + 1)


def size_labels(uv_px: FloatArray, visible: BoolArray, hand_px: FloatArray,
                small_hand_px: tuple) -> tuple[FloatArray, BoolArray]:
    """Tip labels of a batch with the hands' sizes in the crops (step 7).

    Parameters
    ----------
    uv_px : (B, 5, 2) float64
    visible : (B, 5) bool
    hand_px : (B,) float64
        Each crop's hand size (:func:`hand_size_px` times the crop's scale).
    small_hand_px : (float, float)
        ``(lo, hi)``: below ``lo`` the tips become negatives (hidden, no position, so no cell
        is ignored around them), from ``lo`` to ``hi`` hidden (ignored around them).

    Returns
    -------
    uv_px : (B, 5, 2) float64
    visible : (B, 5) bool
    """
    lo, hi = small_hand_px
    uv = np.where((hand_px < lo)[:, None, None], np.nan, uv_px)
    return uv, visible & (hand_px >= hi)[:, None]


def photometric(crop: UInt8Array, rng: np.random.Generator) -> UInt8Array:
    """Random contrast, brightness, gamma, white balance, blur and JPEG (step 6)."""
    x = crop.astype(np.float32) / 255.0
    x = x ** rng.uniform(0.7, 1.4)
    gain = rng.uniform(0.6, 1.3) * rng.uniform(0.85, 1.15, 3)
    x = x * gain.astype(np.float32) + np.float32(rng.uniform(-0.1, 0.1))
    out = np.clip(x * 255.0 + 0.5, 0.0, 255.0).astype(np.uint8)
    if rng.random() < 0.5:
        out = cv2.GaussianBlur(out, (0, 0), rng.uniform(0.3, 1.5))
    if rng.random() < 0.3:
        ok, jpeg = cv2.imencode('.jpg', out, [cv2.IMWRITE_JPEG_QUALITY,
                                              int(rng.integers(30, 91))])
        if ok:
            out = cv2.imdecode(jpeg, cv2.IMREAD_UNCHANGED)
    return out
