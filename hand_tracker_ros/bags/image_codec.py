"""The one image decoder of the package: camera messages to ``(H, W, 3) uint8`` RGB.

Every path that reads camera images (offline bags, the live ``features`` and
``salient_points`` nodes, the evaluation figures) decodes through :func:`image_from_msg`. It
takes any object with the fields of ``sensor_msgs/msg/Image`` or
``sensor_msgs/msg/CompressedImage`` (rclpy messages, rosbags messages), so it needs no ROS
import.

Raw images arrive as a byte buffer plus ``width``, ``height``, ``encoding`` and ``step`` (bytes
per row, >= ``width * channels * bytes_per_channel``; the excess is row padding).
:func:`image_from_buffer` checks every one of these against the others, then converts with
OpenCV (``cv2.cvtColor``): the colour and YUV 4:2:2 encodings, and the 8-bit Bayer mosaics with
the ``cv2.COLOR_Bayer*`` codes that cv_bridge uses for the ROS pattern names (OpenCV names a
mosaic by the second row's pixels 1-2: ROS ``bayer_rggb8`` is OpenCV ``BayerBG``). Float images
(``32FC1``) follow the ROS display convention of intensities in [0, 1]; they are clipped to that
range and scaled by 255. 16-bit images keep their 8 high bits.

Compressed images (``format`` ``jpeg``/``png``, optionally in image_transport's
``"<encoding>; <jpeg|png> compressed <encoding>"`` form) are decoded with ``cv2.imdecode``,
which reads the codec from the bytes. :func:`compress_rgb` is the inverse, for writing bags.
"""
from __future__ import annotations

from typing import Any

import cv2
import numpy as np

from hand_tracker_ros._typing import UInt8Array
from hand_tracker_ros.checks import check_image_size, check_rgb
from hand_tracker_ros.errors import ImageFormatError

# encoding -> (channels, numpy dtype of one channel, cv2 conversion to RGB or None for a copy).
# '8UC3' is taken as bgr8, the cv_bridge convention for OpenCV images; 'uyvy'/'yuyv' are the
# newer sensor_msgs names of 'yuv422'/'yuv422_yuy2'.
_LAYOUTS: dict[str, tuple[int, str, int | None]] = {
    'rgb8': (3, 'u1', None),
    'bgr8': (3, 'u1', cv2.COLOR_BGR2RGB),
    '8UC3': (3, 'u1', cv2.COLOR_BGR2RGB),
    'rgba8': (4, 'u1', cv2.COLOR_RGBA2RGB),
    'bgra8': (4, 'u1', cv2.COLOR_BGRA2RGB),
    'mono8': (1, 'u1', cv2.COLOR_GRAY2RGB),
    '8UC1': (1, 'u1', cv2.COLOR_GRAY2RGB),
    'mono16': (1, 'u2', cv2.COLOR_GRAY2RGB),
    '16UC1': (1, 'u2', cv2.COLOR_GRAY2RGB),
    '32FC1': (1, 'f4', cv2.COLOR_GRAY2RGB),
    'yuv422': (2, 'u1', cv2.COLOR_YUV2RGB_UYVY),
    'uyvy': (2, 'u1', cv2.COLOR_YUV2RGB_UYVY),
    'yuv422_yuy2': (2, 'u1', cv2.COLOR_YUV2RGB_YUY2),
    'yuyv': (2, 'u1', cv2.COLOR_YUV2RGB_YUY2),
    'bayer_rggb8': (1, 'u1', cv2.COLOR_BayerBG2RGB),
    'bayer_bggr8': (1, 'u1', cv2.COLOR_BayerRG2RGB),
    'bayer_gbrg8': (1, 'u1', cv2.COLOR_BayerGR2RGB),
    'bayer_grbg8': (1, 'u1', cv2.COLOR_BayerGB2RGB),
}
SUPPORTED_ENCODINGS: tuple[str, ...] = tuple(_LAYOUTS)
# Encodings whose 2-pixel macro-pixels need an even width (4:2:2 chroma) or whose 2x2 tiles
# need an even width and height (Bayer).
_EVEN_WIDTH = ('yuv422', 'uyvy', 'yuv422_yuy2', 'yuyv')
_EVEN_SIZE = tuple(e for e in _LAYOUTS if e.startswith('bayer_'))
COMPRESSED_FORMATS = ('jpeg', 'png')
_JPEG_QUALITY = 95  # compressed_image_transport's default jpeg_quality


def image_from_msg(msg: Any, *, source: str,
                   expected_size_px: tuple[int, int] | None = None) -> UInt8Array:
    """Decode a ``sensor_msgs/msg/Image`` or ``sensor_msgs/msg/CompressedImage`` to RGB.

    Parameters
    ----------
    msg : Image or CompressedImage
        Any object with those fields (a CompressedImage is recognised by its ``format``).
    source : str
        Topic or camera name, the prefix of every error message.
    expected_size_px : (int, int), optional
        ``(width, height)`` from camera_info or the rig; a mismatch raises.

    Returns
    -------
    image_rgb : (H, W, 3) uint8
        Contiguous RGB copy, never a view of the message buffer.

    Raises
    ------
    ImageFormatError
        See :func:`image_from_buffer` and :func:`image_from_compressed`.
    """
    if hasattr(msg, 'format'):
        return image_from_compressed(msg.data, msg.format, source=source,
                                     expected_size_px=expected_size_px)
    return image_from_buffer(msg.data, int(msg.width), int(msg.height), msg.encoding,
                             int(msg.step), is_bigendian=bool(msg.is_bigendian), source=source,
                             expected_size_px=expected_size_px)


def _bytes_of(data: bytes | memoryview | np.ndarray) -> np.ndarray:
    """The raw bytes of a message buffer as a flat uint8 array (an ndarray as its bytes)."""
    if isinstance(data, np.ndarray):
        return np.ascontiguousarray(data).reshape(-1).view(np.uint8)
    return np.frombuffer(data, dtype=np.uint8)


def _rows(data: bytes | memoryview | np.ndarray, height: int, step: int,
          source: str) -> np.ndarray:
    """View the buffer as ``(height, step)`` uint8 rows, checking its length."""
    buf = _bytes_of(data)
    if buf.size != height * step:
        msg = (f'{source}: buffer holds {buf.size} bytes but height x step = '
               f'{height} x {step} = {height * step}')
        raise ImageFormatError(msg)
    return buf.reshape(height, step)


def _check_layout(source: str, encoding: str, width: int, height: int) -> None:
    if encoding not in _LAYOUTS:
        supported = ', '.join(SUPPORTED_ENCODINGS)
        msg = f'{source}: unsupported encoding {encoding!r}; supported: {supported}'
        raise ImageFormatError(msg)
    if width <= 0 or height <= 0:
        msg = f'{source}: image size must be positive, got {width}x{height}'
        raise ImageFormatError(msg)
    if (encoding in _EVEN_WIDTH + _EVEN_SIZE and width % 2) or (
            encoding in _EVEN_SIZE and height % 2):
        what = 'width and height' if encoding in _EVEN_SIZE else 'width'
        msg = f'{source}: {encoding} needs an even {what}, got {width}x{height}'
        raise ImageFormatError(msg)


def image_from_buffer(data: bytes | memoryview | np.ndarray, width: int, height: int,
                      encoding: str, step: int, *, is_bigendian: bool = False,
                      source: str = 'image',
                      expected_size_px: tuple[int, int] | None = None) -> UInt8Array:
    """Decode a raw image buffer (the fields of ``sensor_msgs/Image``) into an RGB array.

    Parameters
    ----------
    data : bytes, memoryview, array.array or ndarray
        ``height * step`` bytes, row-major (an ndarray is read as its raw bytes).
    width, height : int
        Image size in px (> 0; even for YUV 4:2:2, even both for Bayer).
    encoding : str
        One of :data:`SUPPORTED_ENCODINGS`.
    step : int
        Bytes per row, including padding.
    is_bigendian : bool
        Byte order of multi-byte channels (mono16, 16UC1, 32FC1).
    source : str
        Topic or camera name, the prefix of every error message.
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
    _check_layout(source, encoding, width, height)
    check_image_size(source, width, height, expected_size_px)
    channels, kind, code = _LAYOUTS[encoding]
    dtype = np.dtype(kind).newbyteorder('>' if is_bigendian else '<')
    row_bytes = width * channels * dtype.itemsize
    if step < row_bytes:
        msg = (f'{source}: step {step} is smaller than width x bytes per pixel = '
               f'{width} x {channels * dtype.itemsize} = {row_bytes} for {encoding}')
        raise ImageFormatError(msg)
    rows = _rows(data, height, step, source)
    pixels = np.ascontiguousarray(rows[:, :row_bytes]).view(dtype).reshape(
        height, width, channels)
    pixels = _to_uint8(pixels, encoding, source)
    if code is None:
        return np.array(pixels, dtype=np.uint8, copy=True)
    return np.asarray(cv2.cvtColor(pixels[:, :, 0] if channels == 1 else pixels, code), np.uint8)


def _to_uint8(pixels: np.ndarray, encoding: str, source: str) -> np.ndarray:
    """``(H, W, ch)`` pixels reduced to 8 bits per channel (float: [0, 1] -> [0, 255])."""
    if pixels.dtype.kind == 'f':
        if not np.all(np.isfinite(pixels)):
            bad = int(pixels.size - np.count_nonzero(np.isfinite(pixels)))
            msg = f'{source}: {encoding} image holds {bad} non-finite values'
            raise ImageFormatError(msg)
        return np.rint(np.clip(pixels, 0.0, 1.0) * 255.0).astype(np.uint8)
    if pixels.dtype.itemsize == 2:
        return (pixels.astype(np.uint16) >> 8).astype(np.uint8)
    return pixels


def image_from_compressed(data: bytes | memoryview | np.ndarray, fmt: str, *, source: str,
                          expected_size_px: tuple[int, int] | None = None) -> UInt8Array:
    """Decode the bytes of a ``sensor_msgs/CompressedImage`` (jpeg or png) into RGB.

    Parameters
    ----------
    data : bytes, memoryview, array.array or ndarray
        The compressed file's bytes.
    fmt : str
        The message's ``format``; 16-bit depth images (``compressedDepth``) are refused.
    source : str
        Topic or camera name, the prefix of every error message.
    expected_size_px : (int, int), optional
        ``(width, height)`` from camera_info; a mismatch raises.

    Returns
    -------
    image_rgb : (H, W, 3) uint8

    Raises
    ------
    ImageFormatError
        Empty or undecodable data, a depth format, or a size contradicting
        ``expected_size_px``.
    """
    if 'compresseddepth' in fmt.lower():
        msg = (f'{source}: CompressedImage format {fmt!r} is a depth image; expected a '
               f'{" or ".join(COMPRESSED_FORMATS)} camera image')
        raise ImageFormatError(msg)
    buf = _bytes_of(data)
    bgr = cv2.imdecode(buf, cv2.IMREAD_COLOR) if buf.size else None
    if bgr is None:
        msg = (f'{source}: cannot decode {buf.size} bytes of CompressedImage format {fmt!r} '
               f'(expected {" or ".join(COMPRESSED_FORMATS)})')
        raise ImageFormatError(msg)
    check_image_size(source, bgr.shape[1], bgr.shape[0], expected_size_px)
    return np.asarray(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB), np.uint8)


def compress_rgb(image_rgb: UInt8Array, codec: str) -> tuple[np.ndarray, str]:
    """Encode an RGB image as a ``sensor_msgs/CompressedImage`` payload.

    Parameters
    ----------
    image_rgb : (H, W, 3) uint8
    codec : str
        ``jpeg`` (quality 95, as compressed_image_transport) or ``png``.

    Returns
    -------
    data : (N,) uint8
        The file's bytes.
    fmt : str
        The ``format`` field in compressed_image_transport's form, e.g.
        ``'rgb8; jpeg compressed bgr8'``.
    """
    if codec not in COMPRESSED_FORMATS:
        msg = f'codec must be one of {", ".join(COMPRESSED_FORMATS)}, got {codec!r}'
        raise ImageFormatError(msg)
    check_rgb('image_rgb', image_rgb)
    params = [cv2.IMWRITE_JPEG_QUALITY, _JPEG_QUALITY] if codec == 'jpeg' else []
    ok, data = cv2.imencode(f'.{codec}', cv2.cvtColor(image_rgb, cv2.COLOR_RGB2BGR), params)
    if not ok:
        msg = f'OpenCV could not encode a {image_rgb.shape} image as {codec}'
        raise ImageFormatError(msg)
    return data.reshape(-1), f'rgb8; {codec} compressed bgr8'
