r"""Per-pixel channels and pixel-pair patch features of the fingertip detector.

Channels (all uint8, stacked ``(4, H, W)``), computed from the RGB image after a 3 x 3 box
blur (which averages out per-pixel sensor noise before any pixel-pair difference):

0. luma Y, 1. chroma Cr, 2. chroma Cb (OpenCV's YCrCb),
3. skin likelihood :math:`s = 255\, P(\text{hand} \mid Cr, Cb)`, looked up in a
   ``(64, 64)`` table indexed by ``(Cr >> 2, Cb >> 2)`` that training estimates from
   histograms of hand and all pixels (:func:`skin_table`), then averaged over a 5 x 5 box
   (per-pixel likelihood is noisy; the averaged one outlines the finger shape: it raised
   the held-out average precision of tip pixels from 0.25 to 0.29 in our ablation).

A feature ``k`` of the bank ``(F, 6) int32`` rows ``(c, dy1, dx1, dy2, dx2, pair)`` evaluated
at pixel ``p = (y, x)`` is (Hough-forest binary tests, Gall & Lempitsky 2009)

.. math:: f_k(p) = I_c(p + o_1) - [\text{pair}]\, I_c(p + o_2)

with coordinates clamped to the image (replicated border). Training and inference both call
:func:`feature_value`, so the forest sees bit-identical features in both.

Candidates are the pixels of a regular grid whose box-averaged skin likelihood is at least
the model's gate (:func:`gate_image`, :func:`candidates`); only they are described and vote.

The kernels are numba ``@njit(cache=True)``: per-pixel tests with clamped coordinates are a
scalar loop numpy cannot express without materialising every offset image, and
``cache=True`` keeps the compiled code on disk so only the first process compiles it.
"""
from __future__ import annotations

import cv2
import numba
import numpy as np

from hand_tracker_ros._typing import Int32Array, IntArray, UInt8Array

N_CHANNELS = 4
SKIN_CHANNEL = 3
# Chroma bins of the skin table: 256 / 4 levels per axis keeps ~100 training pixels per
# occupied bin while still separating skin from near-gray backgrounds.
SKIN_SHIFT = 2
SKIN_BINS = 256 >> SKIN_SHIFT
GATE_BOX_PX = 9
SKIN_BOX_PX = 5


def compute_channels(image_rgb: UInt8Array, skin_lut: UInt8Array) -> UInt8Array:
    """The detector channels of one image.

    Parameters
    ----------
    image_rgb : (H, W, 3) uint8
    skin_lut : (SKIN_BINS, SKIN_BINS) uint8
        Skin likelihood per (Cr, Cb) bin, 0-255.

    Returns
    -------
    channels : (4, H, W) uint8
        Y, Cr, Cb, skin likelihood.
    """
    ycrcb = cv2.cvtColor(cv2.blur(image_rgb, (3, 3)), cv2.COLOR_RGB2YCrCb)
    out = np.empty((N_CHANNELS, *image_rgb.shape[:2]), dtype=np.uint8)
    out[:3] = cv2.split(ycrcb)
    # One flat index per pixel: a 1-D take is ~6x faster than 2-D fancy indexing.
    index = (out[1] >> SKIN_SHIFT).astype(np.uint16) * SKIN_BINS + (out[2] >> SKIN_SHIFT)
    skin = skin_lut.ravel()[index]
    out[SKIN_CHANNEL] = cv2.blur(skin, (SKIN_BOX_PX, SKIN_BOX_PX))
    return out


def skin_table(hand_counts: np.ndarray, all_counts: np.ndarray) -> UInt8Array:
    """Skin likelihood table from chroma histograms.

    Parameters
    ----------
    hand_counts, all_counts : (SKIN_BINS, SKIN_BINS) float64
        Pixel counts per (Cr, Cb) bin over hand pixels and over all pixels.

    Returns
    -------
    lut : (SKIN_BINS, SKIN_BINS) uint8
        ``255 * (hand + 1) / (all + 2)``: the posterior with a Laplace prior, so empty bins
        get 0.5 * 255 / 2 and are not trusted either way; smoothed by a 3 x 3 blur because
        neighbouring chroma bins have similar odds.
    """
    ratio = (hand_counts + 1.0) / (all_counts + 2.0)
    ratio = cv2.blur(ratio, (3, 3), borderType=cv2.BORDER_REPLICATE)
    return np.clip(np.rint(255.0 * ratio), 0, 255).astype(np.uint8)


def chroma_histogram(channels: UInt8Array, mask: np.ndarray) -> np.ndarray:
    """(SKIN_BINS, SKIN_BINS) float64 counts of the (Cr, Cb) bins of the pixels in ``mask``."""
    cr = channels[1][mask] >> SKIN_SHIFT
    cb = channels[2][mask] >> SKIN_SHIFT
    flat = np.bincount(cr.astype(np.int64) * SKIN_BINS + cb, minlength=SKIN_BINS ** 2)
    return flat.reshape(SKIN_BINS, SKIN_BINS).astype(np.float64)


def gate_image(channels: UInt8Array) -> UInt8Array:
    """Skin likelihood averaged over a ``GATE_BOX_PX`` box (H, W) uint8.

    The average, not the pixel value, is gated: the shaded side of a finger has near-gray
    chroma (low likelihood) but always lies next to well-lit skin.
    """
    return cv2.blur(channels[SKIN_CHANNEL], (GATE_BOX_PX, GATE_BOX_PX))


def candidates(gate_mask: np.ndarray, stride: int) -> tuple[IntArray, IntArray]:
    """Grid pixels inside the gate mask (``gate_image(channels) >= gate``, (H, W) bool).

    Returns
    -------
    ys, xs : (N,) int64
        Row and column of each candidate (row-major order).
    """
    half = stride // 2
    gy, gx = np.nonzero(gate_mask[half::stride, half::stride])
    return gy * stride + half, gx * stride + half


def random_bank(n_features: int, window_px: int, pair_fraction: float,
                rng: np.random.Generator) -> Int32Array:
    """A random bank of pixel tests.

    Parameters
    ----------
    n_features : int
    window_px : int
        Offsets are uniform in ``[-window_px, window_px]`` per axis.
    pair_fraction : float
        Fraction of two-pixel (difference) tests; the rest are single-pixel values.
    rng : numpy.random.Generator

    Returns
    -------
    bank : (F, 6) int32
        Rows ``(channel, dy1, dx1, dy2, dx2, pair)``.
    """
    bank = np.zeros((n_features, 6), dtype=np.int32)
    bank[:, 0] = rng.integers(0, N_CHANNELS, n_features)
    bank[:, 1:5] = rng.integers(-window_px, window_px + 1, (n_features, 4))
    bank[:, 5] = rng.random(n_features) < pair_fraction
    bank[bank[:, 5] == 0, 3:5] = 0
    return bank


@numba.njit(cache=True, nogil=True, inline='always')
def feature_value(channels: UInt8Array, bank: Int32Array, k: int, y: int, x: int) -> int:
    """Feature ``k`` of the bank at pixel (y, x) (see the module docstring)."""
    height, width = channels.shape[1], channels.shape[2]
    c = bank[k, 0]
    y1 = min(max(y + bank[k, 1], 0), height - 1)
    x1 = min(max(x + bank[k, 2], 0), width - 1)
    value = np.int32(channels[c, y1, x1])
    if bank[k, 5]:
        y2 = min(max(y + bank[k, 3], 0), height - 1)
        x2 = min(max(x + bank[k, 4], 0), width - 1)
        value -= np.int32(channels[c, y2, x2])
    return value


@numba.njit(cache=True, nogil=True)
def feature_matrix(channels: UInt8Array, bank: Int32Array, ys: IntArray,
                   xs: IntArray) -> np.ndarray:
    """Every bank feature at every pixel: (N, F) int16 (training and the oracle test)."""
    out = np.empty((ys.shape[0], bank.shape[0]), dtype=np.int16)
    for i in range(ys.shape[0]):
        for k in range(bank.shape[0]):
            out[i, k] = feature_value(channels, bank, k, ys[i], xs[i])
    return out
