"""Fixtures of the renderer tests (the meshes and ray-casting oracles are in ray_oracle.py)."""
from __future__ import annotations

import numpy as np
import pytest


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(1234)
