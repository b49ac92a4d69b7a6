"""Boundary checks for arrays: shape, dtype and finiteness, with scipy-style messages."""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from hand_tracker_ros.errors import ShapeError


def _shape_text(shape: Sequence[int | None]) -> str:
    return '(' + ', '.join('*' if s is None else str(s) for s in shape) + ')'


def check_shape(name: str, array: np.ndarray, shape: Sequence[int | None]) -> None:
    """Raise :class:`ShapeError` unless ``array.shape`` matches ``shape``.

    ``None`` in ``shape`` is a wildcard. The message shows expected vs actual, e.g.
    ``\\`uv_px\\` must be (*, 5, 2), got (3, 4, 2)``.
    """
    actual = np.shape(array)
    if len(actual) != len(shape) or any(
            s is not None and s != a for s, a in zip(shape, actual)):
        msg = f'`{name}` must be {_shape_text(shape)}, got {tuple(actual)}'
        raise ShapeError(msg)


def check_finite(name: str, array: np.ndarray) -> None:
    """Raise :class:`ShapeError` if ``array`` holds NaN or infinite values."""
    if not np.all(np.isfinite(array)):
        bad = int(np.size(array) - np.count_nonzero(np.isfinite(array)))
        msg = f'`{name}` holds {bad} non-finite values'
        raise ShapeError(msg)
