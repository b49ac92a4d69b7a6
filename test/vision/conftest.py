"""Synthetic frames shared by the vision tests: a textured background and a skin blob."""
from __future__ import annotations

from collections.abc import Callable

import cv2
import numpy as np
import pytest

SKIN_RGB = (224, 172, 140)
HEIGHT, WIDTH = 120, 160


def textured(rng: np.random.Generator, height: int = HEIGHT, width: int = WIDTH
             ) -> np.ndarray:
    """(H, W, 3) uint8 low-saturation texture (blurred noise around mid gray)."""
    gray = cv2.GaussianBlur(rng.normal(128.0, 60.0, (height, width)), (0, 0), 1.5)
    tint = rng.normal(0.0, 6.0, (height, width, 3))
    return np.clip(gray[..., None] + tint, 0, 255).astype(np.uint8)


def draw_blob(image: np.ndarray, center_uv: tuple[int, int], axes: tuple[int, int] = (22, 32)
              ) -> np.ndarray:
    """Copy of ``image`` with a filled skin-coloured ellipse."""
    out = image.copy()
    cv2.ellipse(out, center_uv, axes, 0, 0, 360, SKIN_RGB, -1)
    return out


def blob_mask(shape_hw: tuple[int, int], center_uv: tuple[int, int],
              axes: tuple[int, int] = (22, 32)) -> np.ndarray:
    out = np.zeros(shape_hw, dtype=np.uint8)
    cv2.ellipse(out, center_uv, axes, 0, 0, 360, 255, -1)
    return out > 0


@pytest.fixture
def make_texture() -> Callable[..., np.ndarray]:
    """The :func:`textured` factory: ``make_texture(rng, height, width)``."""
    return textured


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


@pytest.fixture
def scene(rng: np.random.Generator) -> Callable[..., tuple[np.ndarray, np.ndarray]]:
    """Factory: ``scene(center_uv)`` -> (image_rgb (H, W, 3) uint8, truth mask (H, W) bool)
    on one fixed background."""
    background = textured(rng)

    def make(center_uv: tuple[int, int] = (80, 60)) -> tuple[np.ndarray, np.ndarray]:
        return draw_blob(background, center_uv), blob_mask(background.shape[:2], center_uv)

    make.background = background  # type: ignore[attr-defined]
    return make
