r"""Deterministic textured, optionally cluttered, RGB backgrounds for synthetic frames.

Kinds (all drawn from ``np.random.default_rng(seed)``, so a seed gives identical bytes):

- ``noise``: smooth value noise, a sum of octaves of uniform random grids upsampled with
  bicubic interpolation, weights halving per octave, mapped between two random colours;
- ``stripes``: :math:`t = \tfrac12 + \tfrac12 \sin(2\pi (x\cos\phi + y\sin\phi)/p)` blending
  two colours, random angle :math:`\phi` and period p;
- ``blobs``: a base colour plus a sum of random isotropic Gaussian colour blobs.

Clutter adds random filled or outlined rectangles, ellipses and thick lines with strong
edges; a fraction of them is skin-coloured, as distractors for colour- and edge-based
detection. Shapes are drawn with OpenCV's (deterministic) rasterization.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from hand_tracker_ros._typing import FloatArray, UInt8Array
from hand_tracker_ros.config import param
from hand_tracker_ros.errors import ConfigError

_SKIN_RGB = np.array([224.0, 172.0, 145.0])


@dataclass(frozen=True)
class BackgroundConfig:
    """What background to draw."""

    kind: str = param('noise', 'texture kind', choices=('noise', 'stripes', 'blobs'))
    n_clutter: int = param(0, 'number of cluttering shapes (0: none)', low=0, high=500)
    skin_fraction: float = param(0.2, 'fraction of clutter shapes that are skin-coloured',
                                 low=0.0, high=1.0)


def _random_colours(rng: np.random.Generator, n: int) -> FloatArray:
    return rng.uniform(20.0, 235.0, (n, 3))


def _noise(rng: np.random.Generator, width: int, height: int) -> FloatArray:
    t = np.zeros((height, width))
    weight = 1.0
    for cells in (3, 6, 12, 24):
        grid = rng.random((cells * height // width + 2, cells + 2))
        t += weight * cv2.resize(grid, (width, height), interpolation=cv2.INTER_CUBIC)
        weight /= 2.0
    t = (t - t.min()) / max(np.ptp(t), 1e-12)
    c0, c1 = _random_colours(rng, 2)
    return c0 + t[..., None] * (c1 - c0)


def _stripes(rng: np.random.Generator, width: int, height: int) -> FloatArray:
    phi = rng.uniform(0.0, np.pi)
    period = rng.uniform(8.0, 40.0) * width / 320.0
    y, x = np.mgrid[0:height, 0:width].astype(np.float64)
    t = 0.5 + 0.5 * np.sin(2.0 * np.pi * (x * np.cos(phi) + y * np.sin(phi)) / period)
    c0, c1 = _random_colours(rng, 2)
    return c0 + t[..., None] * (c1 - c0)


def _blobs(rng: np.random.Generator, width: int, height: int) -> FloatArray:
    image = np.broadcast_to(_random_colours(rng, 1)[0], (height, width, 3)).copy()
    y, x = np.mgrid[0:height, 0:width].astype(np.float64)
    for _ in range(int(rng.integers(6, 14))):
        cx, cy = rng.uniform(0, width), rng.uniform(0, height)
        sigma = rng.uniform(0.05, 0.2) * width
        g = np.exp(-((x - cx) ** 2 + (y - cy) ** 2) / (2.0 * sigma ** 2))
        image += g[..., None] * (_random_colours(rng, 1)[0] - image)
    return image


def _draw_clutter(rng: np.random.Generator, image: UInt8Array, n: int,
                  skin_fraction: float) -> None:
    height, width = image.shape[:2]
    scale = max(width, height)
    for _ in range(n):
        skin = rng.random() < skin_fraction
        colour = (_SKIN_RGB * rng.uniform(0.8, 1.1) if skin else _random_colours(rng, 1)[0])
        colour_t = tuple(float(c) for c in np.clip(colour, 0, 255))
        kind = int(rng.integers(3))
        thickness = -1 if rng.random() < 0.5 else int(rng.integers(2, 5))
        p0 = (int(rng.integers(width)), int(rng.integers(height)))
        size = rng.uniform(0.03, 0.2, 2) * scale
        if kind == 0:
            p1 = (int(p0[0] + size[0]), int(p0[1] + size[1]))
            cv2.rectangle(image, p0, p1, colour_t, thickness, cv2.LINE_8)
        elif kind == 1:
            axes = (int(size[0] / 2) + 1, int(size[1] / 2) + 1)
            angle = float(rng.uniform(0.0, 180.0))
            cv2.ellipse(image, p0, axes, angle, 0.0, 360.0, colour_t, thickness, cv2.LINE_8)
        else:
            p1 = (int(rng.integers(width)), int(rng.integers(height)))
            cv2.line(image, p0, p1, colour_t, max(thickness, 2), cv2.LINE_8)


def make_background(width: int, height: int, *, seed: int = 0,
                    config: BackgroundConfig = BackgroundConfig()) -> UInt8Array:
    """A deterministic RGB background.

    Parameters
    ----------
    width, height : int
        Image size (px).
    seed : int
        Seed; the same seed and config give byte-identical images.
    config : BackgroundConfig
        Texture kind and clutter.

    Returns
    -------
    image : (H, W, 3) uint8
        rgb8 image.
    """
    if width <= 0 or height <= 0:
        msg = f'background size must be positive, got {width}x{height}'
        raise ConfigError(msg)
    makers = {'noise': _noise, 'stripes': _stripes, 'blobs': _blobs}
    if config.kind not in makers:
        msg = f'`kind` must be one of {sorted(makers)}, got {config.kind!r}'
        raise ConfigError(msg)
    rng = np.random.default_rng(seed)
    image = np.clip(np.rint(makers[config.kind](rng, width, height)), 0, 255).astype(np.uint8)
    _draw_clutter(rng, image, config.n_clutter, config.skin_fraction)
    return image
