"""Structured edge noise: what edge detection on real footage adds and misses.

Ballan et al.'s supplementary (Fig. 3) adds *and* subtracts structured noise to the edge
images of synthetic sequences so that the experiments resemble real data. We model:

- **clutter strokes** added: smooth random curves (a random walk whose heading drifts slowly),
  as produced by texture and background structure;
- **blobs** added: closed outlines of random ellipses, as produced by shadows, wrinkles,
  nails and specularities;
- **gaps** removed: true edge pixels erased inside random discs centred on edge pixels, as
  produced by low contrast between the hand and its background.

Each added pixel gets the orientation of its curve's normal, so an orientation check treats
clutter like a real edge. The noise is a deterministic function of the rng state.

References: docs/references.md.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from hand_tracker_ros._typing import BoolArray, Float32Array
from hand_tracker_ros.config import param


@dataclass(frozen=True)
class EdgeNoiseConfig:
    """Amount of structured edge noise (densities are per 100 x 100 px of image)."""

    enabled: bool = param(False, 'apply structured edge noise (synthetic evaluation)')
    strokes_per_10k_px: float = param(1.5, 'clutter strokes added', low=0.0, high=100.0)
    stroke_length_px: float = param(40.0, 'mean stroke length', unit='px', low=1.0, high=1000.0)
    blobs_per_10k_px: float = param(0.6, 'blob outlines added', low=0.0, high=100.0)
    blob_radius_px: float = param(6.0, 'mean blob radius', unit='px', low=1.0, high=200.0)
    gap_fraction: float = param(0.15, 'fraction of true edge pixels erased (approximately)',
                                low=0.0, high=1.0)
    gap_radius_px: float = param(4.0, 'radius of an erased disc', unit='px', low=1.0,
                                 high=100.0)


def _draw_strokes(shape: tuple[int, int], rng: np.random.Generator, count: int,
                  length_px: float) -> tuple[np.ndarray, np.ndarray]:
    """Draw ``count`` strokes; each segment is drawn with its own label so that its
    pixels can look up the segment's normal direction afterwards."""
    h, w = shape
    labels = np.zeros(shape, np.int32)
    normals = [0.0]
    for _ in range(count):
        n = max(2, int(rng.exponential(length_px) / 2.0))
        heading = rng.uniform(0.0, 2.0 * np.pi) + np.cumsum(rng.normal(0.0, 0.15, n))
        steps = 2.0 * np.stack([np.cos(heading), np.sin(heading)], axis=1)
        pts = np.round(np.array([rng.uniform(0, w), rng.uniform(0, h)])
                       + np.cumsum(steps, axis=0)).astype(np.int32)
        for a, b, head in zip(pts[:-1], pts[1:], heading[1:]):
            cv2.line(labels, (int(a[0]), int(a[1])), (int(b[0]), int(b[1])), len(normals), 1)
            normals.append((head + np.pi / 2.0) % (2.0 * np.pi))
    return labels, np.asarray(normals, np.float32)


def _draw_blob(canvas: np.ndarray, angle: np.ndarray, rng: np.random.Generator,
               radius_px: float) -> None:
    h, w = canvas.shape
    center = (int(rng.uniform(0, w)), int(rng.uniform(0, h)))
    axes = tuple(int(max(1.0, rng.exponential(radius_px))) for _ in range(2))
    mask = np.zeros_like(canvas)
    cv2.ellipse(mask, center, axes, float(rng.uniform(0, 180)), 0, 360, 1, 1)
    vv, uu = np.nonzero(mask)
    canvas |= mask
    angle[vv, uu] = np.arctan2(vv - center[1], uu - center[0]) % (2.0 * np.pi)


def add_edge_noise(edges: BoolArray, orientation_rad: Float32Array, rng: np.random.Generator,
                   config: EdgeNoiseConfig) -> tuple[BoolArray, Float32Array]:
    """Add clutter and remove true edges.

    Parameters
    ----------
    edges : (H, W) bool
        Edge pixels of the clean image.
    orientation_rad : (H, W) float32
        Edge-normal direction per pixel.
    rng : numpy.random.Generator
    config : EdgeNoiseConfig

    Returns
    -------
    noisy_edges : (H, W) bool
    noisy_orientation_rad : (H, W) float32
    """
    if not config.enabled:
        return edges, orientation_rad
    h, w = edges.shape
    area = h * w / 1e4
    kept = edges.astype(np.uint8)
    true_uv = np.flatnonzero(edges)
    n_gaps = int(config.gap_fraction * true_uv.size / (2.0 * config.gap_radius_px))
    for flat in rng.choice(true_uv, size=min(n_gaps, true_uv.size), replace=False):
        cv2.circle(kept, (int(flat % w), int(flat // w)), int(config.gap_radius_px), 0, -1)
    labels, normals = _draw_strokes((h, w), rng, rng.poisson(config.strokes_per_10k_px * area),
                                    config.stroke_length_px)
    added = (labels > 0).astype(np.uint8)
    angle = orientation_rad.copy()
    angle[labels > 0] = normals[labels[labels > 0]]
    for _ in range(rng.poisson(config.blobs_per_10k_px * area)):
        _draw_blob(added, angle, rng, config.blob_radius_px)
    return (kept > 0) | (added > 0), angle
