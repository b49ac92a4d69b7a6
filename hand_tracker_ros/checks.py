"""Boundary checks for arrays: shape, dtype and finiteness, with scipy-style messages."""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from hand_tracker_ros.errors import ImageFormatError, ShapeError


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


def check_image_size(camera_name: str, width: int, height: int,
                     expected_size_px: tuple[int, int] | None) -> None:
    """Raise :class:`ImageFormatError` if the image size contradicts ``expected_size_px``.

    Parameters
    ----------
    camera_name : str
        Used in the message.
    width, height : int
        Image size in px.
    expected_size_px : (int, int) or None
        ``(width, height)`` from the camera calibration (camera_info); None skips the check.
    """
    if expected_size_px is None:
        return
    exp_w, exp_h = expected_size_px
    if (width, height) != (exp_w, exp_h):
        msg = (f'{camera_name}: image is {width}x{height} but camera_info says '
               f'{exp_w}x{exp_h}')
        raise ImageFormatError(msg)


def check_rgb(name: str, image_rgb: np.ndarray,
              size_px: Sequence[int] | None = None) -> None:
    """Raise :class:`ImageFormatError` unless ``image_rgb`` is an ``(H, W, 3) uint8`` array.

    Parameters
    ----------
    name : str
        Argument or camera name used in the message.
    image_rgb : ndarray
        Candidate image.
    size_px : (int, int), optional
        Required ``(width, height)``.
    """
    if not isinstance(image_rgb, np.ndarray):
        msg = f'{name}: expected an (H, W, 3) uint8 array, got {type(image_rgb).__name__}'
        raise ImageFormatError(msg)
    if image_rgb.ndim != 3 or image_rgb.shape[2] != 3 or image_rgb.dtype != np.uint8:
        msg = (f'{name}: expected an (H, W, 3) uint8 RGB image, got shape '
               f'{image_rgb.shape} dtype {image_rgb.dtype}')
        raise ImageFormatError(msg)
    if size_px is not None:
        check_image_size(name, image_rgb.shape[1], image_rgb.shape[0],
                         (int(size_px[0]), int(size_px[1])))
