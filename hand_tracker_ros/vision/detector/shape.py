r"""Shape and edge features of vote peaks for the context verifier (:mod:`.verifier`).

The ring profiles of :func:`.verifier.peak_features` sample the skin channel, the gate
mask and the luma; these add what they miss, from a crop of the image around the peaks:

- the distance (px, at most ``MAX_DISTANCE_PX``) of the peak to the nearest pixel outside
  the gate mask :math:`d_{in}` and to the nearest pixel inside it :math:`d_{out}`, and the
  largest :math:`d_{in}` within ``DISC_RADII_PX`` of the peak: the half-width of the skin
  region near the peak (a finger is narrow, the palm or a knuckle between two fingers is
  wide, clutter stripes have their own widths);
- ring profiles (radii ``RING_RADII_PX``, ``N_ANGLES`` angles) of :math:`d_{in}`, of the
  luma gradient magnitude :math:`|\nabla Y|` and of the gradient magnitude of the
  Gaussian-smoothed (``SKIN_SIGMA_PX``, in uint8) skin likelihood (Sobel, per 255): per
  ring the mean, the maximum and the magnitudes of the circular harmonics
  :math:`k = 1, 2, 3`. The luma gradient outlines a tip seen against the palm, where the
  skin channel is flat.

All terms are invariant to the finger's direction, like the ring profiles. On 400 views of
a validation seed (verifier trained on 1200 fresh views of seed 0, same peaks; a prototype
of these terms on 41 x 41 patches around each peak) they raised the context verifier's
precision / recall at min_score 0.5 from 0.854 / 0.710 to 0.862 / 0.729 with gradient
boosting, and by ~0.01 with the random forest.
"""
from __future__ import annotations

import cv2
import numpy as np

from hand_tracker_ros._typing import Float32Array, FloatArray, UInt8Array
from hand_tracker_ros.vision.detector.channels import SKIN_CHANNEL

MAX_DISTANCE_PX = 40.0
DISC_RADII_PX = (6, 10, 16)
RING_RADII_PX = (3, 6, 9)
N_ANGLES = 16
SKIN_SIGMA_PX = 1.5
N_MAPS = 3
N_SHAPE = 2 + len(DISC_RADII_PX) + 5 * N_MAPS * len(RING_RADII_PX)
_MARGIN_PX = max(DISC_RADII_PX) + 4

_ANGLES = 2.0 * np.pi * np.arange(N_ANGLES) / N_ANGLES
_DFT = np.exp(-1j * np.outer(np.arange(1, 4), _ANGLES)) / N_ANGLES                  # (3, A)
_RING_DY = np.concatenate([r * np.sin(_ANGLES) for r in RING_RADII_PX])
_RING_DX = np.concatenate([r * np.cos(_ANGLES) for r in RING_RADII_PX])


def _disc(radius: int) -> tuple[np.ndarray, np.ndarray]:
    dy, dx = np.mgrid[-radius:radius + 1, -radius:radius + 1]
    inside = dx ** 2 + dy ** 2 <= radius ** 2
    return dy[inside], dx[inside]


_DISCS = tuple(_disc(r) for r in DISC_RADII_PX)


def _gradient_magnitude(image: UInt8Array) -> Float32Array:
    """Sobel gradient magnitude (h, w) float32 of an (h, w) uint8 image, divided by 255.

    Integer derivatives and an exactly rounded square root give the same bits on every run
    (with a float Sobel and ``cv2.magnitude`` two identical training runs differed in the
    last bit of a feature, presumably from alignment-dependent SIMD paths).
    """
    gx = cv2.Sobel(image, cv2.CV_16S, 1, 0).astype(np.float32)
    gy = cv2.Sobel(image, cv2.CV_16S, 0, 1).astype(np.float32)
    return np.sqrt(gx * gx + gy * gy) / np.float32(255.0)


def _maps(channels: UInt8Array, gate_mask: np.ndarray) -> Float32Array:
    """(N_MAPS + 1, h, w) float32: d_in, |grad Y|, |grad skin|, d_out of a crop."""
    gate = gate_mask.astype(np.uint8)
    d_in = cv2.distanceTransform(gate, cv2.DIST_L2, 3)
    d_out = cv2.distanceTransform(1 - gate, cv2.DIST_L2, 3)
    skin = cv2.GaussianBlur(channels[SKIN_CHANNEL], (0, 0), SKIN_SIGMA_PX)
    grads = [_gradient_magnitude(img) for img in (channels[0], skin)]
    return np.stack([np.minimum(d_in, MAX_DISTANCE_PX), *grads,
                     np.minimum(d_out, MAX_DISTANCE_PX)])


def shape_features(uv_px: FloatArray, channels: UInt8Array,
                   gate_mask: np.ndarray) -> Float32Array:
    """Shape and edge features of the vote peaks of one image (see the module docstring).

    The maps are computed on the peaks' bounding box grown by ``_MARGIN_PX`` (clipped to
    the image): distances are measured within that crop.

    Parameters
    ----------
    uv_px : (N, 2) float64
        Peak positions (u, v).
    channels : (C, H, W) uint8
        Detector channels (:func:`.channels.compute_channels`).
    gate_mask : (H, W) bool

    Returns
    -------
    features : (N, N_SHAPE) float32
        ``d_in, d_out``, the largest ``d_in`` per ``DISC_RADII_PX`` radius, then per map
        (``d_in``, ``|grad Y|``, ``|grad skin|``) and ring radius: mean, max, ``|h_1|,
        |h_2|, |h_3|``.
    """
    n = uv_px.shape[0]
    if n == 0:
        return np.zeros((0, N_SHAPE), np.float32)
    rows, cols = gate_mask.shape
    centre = np.rint(uv_px).astype(np.intp)
    x0 = max(int(centre[:, 0].min()) - _MARGIN_PX, 0)
    y0 = max(int(centre[:, 1].min()) - _MARGIN_PX, 0)
    x1 = min(int(centre[:, 0].max()) + _MARGIN_PX + 1, cols)
    y1 = min(int(centre[:, 1].max()) + _MARGIN_PX + 1, rows)
    maps = _maps(channels[:, y0:y1, x0:x1], gate_mask[y0:y1, x0:x1])
    h, w = y1 - y0, x1 - x0
    cu, cv = np.clip(centre[:, 0] - x0, 0, w - 1), np.clip(centre[:, 1] - y0, 0, h - 1)
    columns = [maps[0, cv, cu], maps[N_MAPS, cv, cu]]
    for dy, dx in _DISCS:
        ys = np.clip(cv[:, None] + dy, 0, h - 1)
        xs = np.clip(cu[:, None] + dx, 0, w - 1)
        columns.append(maps[0][ys, xs].max(axis=1))
    ys = np.clip(np.rint(uv_px[:, 1:2] - y0 + _RING_DY), 0, h - 1).astype(np.intp)
    xs = np.clip(np.rint(uv_px[:, 0:1] - x0 + _RING_DX), 0, w - 1).astype(np.intp)
    rings = maps[:N_MAPS][:, ys, xs].reshape(N_MAPS, n, len(RING_RADII_PX), N_ANGLES)
    harmonics = np.abs(rings @ _DFT.T)                                  # (M, N, R, 3)
    stats = np.concatenate([rings.mean(axis=3)[..., None], rings.max(axis=3)[..., None],
                            harmonics], axis=3)                          # (M, N, R, 5)
    return np.concatenate([np.column_stack(columns),
                           stats.transpose(1, 0, 2, 3).reshape(n, -1)],
                          axis=1).astype(np.float32)
