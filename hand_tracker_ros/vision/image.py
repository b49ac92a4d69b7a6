"""Image validation and conversion at the core boundary (no ROS types).

A raw image arrives as a byte buffer plus ``width``, ``height``, ``encoding`` and ``step``
(bytes per row, >= ``width * channels * bytes_per_channel``; the excess is row padding), as in
``sensor_msgs/Image``. :func:`image_from_buffer` checks every one of these against the others
and returns a contiguous ``(H, W, 3) uint8`` RGB array, the one image type the vision core
works with. Float images (``32FC1``) follow the ROS display convention of intensities in
[0, 1]; they are clipped to that range and scaled by 255. ``mono16`` keeps its 8 high bits.
"""
from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np

from hand_tracker_ros._typing import UInt8Array
from hand_tracker_ros.errors import ImageFormatError

# encoding -> (channels, numpy dtype of one channel)
_LAYOUTS: dict[str, tuple[int, str]] = {
    'rgb8': (3, 'u1'),
    'bgr8': (3, 'u1'),
    'rgba8': (4, 'u1'),
    'bgra8': (4, 'u1'),
    'mono8': (1, 'u1'),
    '8UC1': (1, 'u1'),
    '8UC3': (3, 'u1'),
    'mono16': (1, 'u2'),
    '16UC1': (1, 'u2'),
    '32FC1': (1, 'f4'),
}
# Colour conversion to RGB for each multi-channel encoding ('8UC3' is taken as bgr8, the
# cv_bridge convention for OpenCV images).
_TO_RGB = {
    'bgr8': cv2.COLOR_BGR2RGB,
    '8UC3': cv2.COLOR_BGR2RGB,
    'rgba8': cv2.COLOR_RGBA2RGB,
    'bgra8': cv2.COLOR_BGRA2RGB,
}
SUPPORTED_ENCODINGS: tuple[str, ...] = tuple(_LAYOUTS)


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


def _rows(data: bytes | memoryview | np.ndarray, height: int, step: int,
          camera_name: str) -> np.ndarray:
    """View the buffer as ``(height, step)`` uint8 rows, checking its length."""
    if isinstance(data, np.ndarray):
        buf = np.ascontiguousarray(data).reshape(-1).view(np.uint8)
    else:
        buf = np.frombuffer(data, dtype=np.uint8)
    if buf.size != height * step:
        msg = (f'{camera_name}: buffer holds {buf.size} bytes but height x step = '
               f'{height} x {step} = {height * step}')
        raise ImageFormatError(msg)
    return buf.reshape(height, step)


def image_from_buffer(data: bytes | memoryview | np.ndarray, width: int, height: int,
                      encoding: str, step: int, *, is_bigendian: bool = False,
                      camera_name: str = 'image',
                      expected_size_px: tuple[int, int] | None = None) -> UInt8Array:
    """Decode a raw image buffer into an RGB array.

    Parameters
    ----------
    data : bytes, memoryview or ndarray
        ``height * step`` bytes, row-major (an ndarray is read as its raw bytes).
    width, height : int
        Image size in px (> 0).
    encoding : str
        One of :data:`SUPPORTED_ENCODINGS`.
    step : int
        Bytes per row, including padding.
    is_bigendian : bool
        Byte order of multi-byte channels (mono16, 32FC1).
    camera_name : str
        Prefix of every error message.
    expected_size_px : (int, int), optional
        ``(width, height)`` from camera_info; a mismatch raises.

    Returns
    -------
    image_rgb : (H, W, 3) uint8
        Contiguous RGB copy, never a view of ``data``.

    Raises
    ------
    ImageFormatError
        Unsupported encoding, bad size/step/buffer length, size contradicting
        ``expected_size_px``, or non-finite values in a float image.
    """
    if encoding not in _LAYOUTS:
        supported = ', '.join(SUPPORTED_ENCODINGS)
        msg = f'{camera_name}: unsupported encoding {encoding!r}; supported: {supported}'
        raise ImageFormatError(msg)
    if width <= 0 or height <= 0:
        msg = f'{camera_name}: image size must be positive, got {width}x{height}'
        raise ImageFormatError(msg)
    check_image_size(camera_name, width, height, expected_size_px)
    channels, kind = _LAYOUTS[encoding]
    dtype = np.dtype(kind).newbyteorder('>' if is_bigendian else '<')
    row_bytes = width * channels * dtype.itemsize
    if step < row_bytes:
        msg = (f'{camera_name}: step {step} is smaller than width x bytes per pixel = '
               f'{width} x {channels * dtype.itemsize} = {row_bytes} for {encoding}')
        raise ImageFormatError(msg)
    rows = _rows(data, height, step, camera_name)
    pixels = np.ascontiguousarray(rows[:, :row_bytes]).view(dtype).reshape(
        height, width, channels)
    return _to_rgb8(pixels, encoding, camera_name)


def _to_rgb8(pixels: np.ndarray, encoding: str, camera_name: str) -> UInt8Array:
    """Convert ``(H, W, ch)`` pixels of ``encoding`` to contiguous RGB uint8."""
    if pixels.dtype.kind == 'f':
        if not np.all(np.isfinite(pixels)):
            bad = int(pixels.size - np.count_nonzero(np.isfinite(pixels)))
            msg = f'{camera_name}: {encoding} image holds {bad} non-finite values'
            raise ImageFormatError(msg)
        pixels = np.rint(np.clip(pixels, 0.0, 1.0) * 255.0).astype(np.uint8)
    elif pixels.dtype.itemsize == 2:
        pixels = (pixels.astype(np.uint16) >> 8).astype(np.uint8)
    if pixels.shape[2] == 1:
        return cv2.cvtColor(np.ascontiguousarray(pixels[:, :, 0]), cv2.COLOR_GRAY2RGB)
    if encoding in _TO_RGB:
        return cv2.cvtColor(pixels, _TO_RGB[encoding])
    return np.array(pixels, dtype=np.uint8, copy=True)


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


def clip_roi(name: str, roi_px: Sequence[int] | None, width: int, height: int
             ) -> tuple[int, int, int, int]:
    """Clip a region of interest to the image.

    Parameters
    ----------
    name : str
        Camera or argument name used in the message.
    roi_px : (u0, v0, u1, v1) ints, or None
        Half-open pixel box ``[u0, u1) x [v0, v1)``; None means the whole image.
    width, height : int
        Image size in px.

    Returns
    -------
    (u0, v0, u1, v1) : ints
        The box clipped to ``[0, width) x [0, height)``, non-empty.

    Raises
    ------
    ImageFormatError
        The box does not overlap the image.
    """
    if roi_px is None:
        return (0, 0, width, height)
    if len(roi_px) != 4:
        msg = f'{name}: roi_px must be (u0, v0, u1, v1), got {tuple(roi_px)}'
        raise ImageFormatError(msg)
    u0, v0 = max(int(roi_px[0]), 0), max(int(roi_px[1]), 0)
    u1, v1 = min(int(roi_px[2]), width), min(int(roi_px[3]), height)
    if u1 <= u0 or v1 <= v0:
        msg = (f'{name}: roi_px {tuple(int(x) for x in roi_px)} does not overlap the '
               f'{width}x{height} image')
        raise ImageFormatError(msg)
    return (u0, v0, u1, v1)


def to_gray(image_rgb: UInt8Array) -> UInt8Array:
    """Luma of an RGB image (ITU-R BT.601 weights, as cv2).

    Parameters
    ----------
    image_rgb : (H, W, 3) uint8

    Returns
    -------
    gray : (H, W) uint8
    """
    check_rgb('image_rgb', image_rgb)
    return cv2.cvtColor(image_rgb, cv2.COLOR_RGB2GRAY)
