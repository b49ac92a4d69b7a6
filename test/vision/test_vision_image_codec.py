"""The one image decoder: every raw encoding, compressed images, and errors that name the
source."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from hand_tracker_ros.bags.convert import compressed_image_msg, image_msg
from hand_tracker_ros.bags.image_codec import (
    compress_rgb,
    image_from_buffer,
    image_from_compressed,
    image_from_msg,
)
from hand_tracker_ros.errors import ImageFormatError


def _rgb(rng: np.random.Generator, h: int = 5, w: int = 7) -> np.ndarray:
    return rng.integers(0, 256, (h, w, 3), dtype=np.uint8)


def _smooth_rgb(h: int = 24, w: int = 32) -> np.ndarray:
    """Gradients in every channel (lossy codecs and demosaicing are near-exact on them)."""
    v, u = np.mgrid[0:h, 0:w].astype(np.float64)
    return np.dstack([40 + 150 * u / w, 60 + 120 * v / h, 200 - 100 * (u + v) / (w + h)]
                     ).astype(np.uint8)


def _padded(rows: np.ndarray, pad: int) -> bytes:
    """Row bytes followed by ``pad`` garbage bytes per row."""
    flat = rows.reshape(rows.shape[0], -1).view(np.uint8)
    garbage = np.full((rows.shape[0], pad), 77, dtype=np.uint8)
    return np.hstack([flat, garbage]).tobytes()


@pytest.mark.parametrize('encoding, convert', [
    ('rgb8', lambda x: x),
    ('bgr8', lambda x: x[..., ::-1]),
    ('rgba8', lambda x: np.dstack([x, np.full(x.shape[:2], 9, np.uint8)])),
    ('bgra8', lambda x: np.dstack([x[..., ::-1], np.full(x.shape[:2], 9, np.uint8)])),
])
def test_color_encodings_with_row_padding_decode_to_rgb(rng, encoding, convert):
    rgb = _rgb(rng)
    raw = np.ascontiguousarray(convert(rgb))
    step = raw.shape[1] * raw.shape[2] + 3
    out = image_from_buffer(_padded(raw, 3), 7, 5, encoding, step)
    assert out.dtype == np.uint8 and out.flags.c_contiguous
    np.testing.assert_array_equal(out, rgb)


def test_mono8_and_memoryview_input(rng):
    gray = rng.integers(0, 256, (4, 6), dtype=np.uint8)
    out = image_from_buffer(memoryview(_padded(gray, 2)), 6, 4, 'mono8', 8)
    np.testing.assert_array_equal(out, np.repeat(gray[..., None], 3, axis=2))


def test_ndarray_buffer_is_read_as_raw_bytes(rng):
    rgb = _rgb(rng)
    np.testing.assert_array_equal(image_from_buffer(rgb, 7, 5, 'rgb8', 21), rgb)
    values = np.array([[0.25, 1.0]], dtype='<f4')
    out = image_from_buffer(values, 2, 1, '32FC1', 8)
    np.testing.assert_array_equal(out[0, :, 0], [64, 255])


def test_mono16_keeps_high_byte_and_respects_endianness():
    values = np.array([[0x1234, 0xFF00]], dtype='>u2')
    out = image_from_buffer(values.tobytes(), 2, 1, 'mono16', 4, is_bigendian=True)
    np.testing.assert_array_equal(out[0, :, 0], [0x12, 0xFF])


def test_float_image_scales_unit_range_and_rejects_nan():
    values = np.array([[0.0, 0.5, 1.0, 2.0]], dtype='<f4')
    out = image_from_buffer(values.tobytes(), 4, 1, '32FC1', 16)
    np.testing.assert_array_equal(out[0, :, 1], [0, 128, 255, 255])
    values[0, 1] = np.nan
    with pytest.raises(ImageFormatError, match=r'cam2: 32FC1 image holds 1 non-finite'):
        image_from_buffer(values.tobytes(), 4, 1, '32FC1', 16, source='cam2')


def test_errors_name_the_problem(rng):
    data = _rgb(rng).tobytes()
    with pytest.raises(ImageFormatError, match=r"unsupported encoding '64FC1'"):
        image_from_buffer(data, 7, 5, '64FC1', 21)
    with pytest.raises(ImageFormatError, match=r'step 20 is smaller than .* = 21 for rgb8'):
        image_from_buffer(data, 7, 5, 'rgb8', 20)
    with pytest.raises(ImageFormatError, match=r'buffer holds 105 bytes but .* = 110'):
        image_from_buffer(data, 7, 5, 'rgb8', 22)
    with pytest.raises(ImageFormatError, match=r'size must be positive, got 0x5'):
        image_from_buffer(b'', 0, 5, 'rgb8', 0)
    with pytest.raises(ImageFormatError,
                       match=r'cam1: image is 7x5 but camera_info says 320x240'):
        image_from_buffer(data, 7, 5, 'rgb8', 21, source='cam1',
                          expected_size_px=(320, 240))


def _two_pixel_yuv(encoding: str, y0: int, y1: int, u: int, v: int) -> bytes:
    """One 4:2:2 macro-pixel, bytes in the order the ROS encoding names (UYVY or YUYV)."""
    return bytes([u, y0, v, y1] if encoding in ('yuv422', 'uyvy') else [y0, u, y1, v])


@pytest.mark.parametrize('encoding', ['yuv422', 'uyvy', 'yuv422_yuy2', 'yuyv'])
def test_yuv422_byte_orders(encoding):
    gray = image_from_buffer(_two_pixel_yuv(encoding, 60, 200, 128, 128), 2, 1, encoding, 4)
    # neutral chroma: two grays, the second brighter (luma is per pixel)
    assert np.ptp(gray[0, 0].astype(int)) <= 2 and np.ptp(gray[0, 1].astype(int)) <= 2
    assert gray[0, 1, 0] > gray[0, 0, 0] + 100
    red = image_from_buffer(_two_pixel_yuv(encoding, 90, 90, 100, 240), 2, 1, encoding, 4)
    assert red[0, 0, 0] > 200 and red[0, 0, 1] < 80 and red[0, 0, 2] < 80


def _mosaic(rgb: np.ndarray, pattern: str) -> np.ndarray:
    """The Bayer mosaic a sensor with filter ``pattern`` (row-major 2x2 tile) records."""
    mosaic = np.zeros(rgb.shape[:2], np.uint8)
    for k, (dv, du) in enumerate([(0, 0), (0, 1), (1, 0), (1, 1)]):
        mosaic[dv::2, du::2] = rgb[dv::2, du::2, 'rgb'.index(pattern[k])]
    return mosaic


@pytest.mark.parametrize('pattern', ['rggb', 'bggr', 'gbrg', 'grbg'])
def test_bayer_patterns_demosaic_to_the_scene(pattern):
    rgb = _smooth_rgb()
    mosaic = _mosaic(rgb, pattern)
    out = image_from_buffer(mosaic.tobytes(), 32, 24, f'bayer_{pattern}8', 32)
    interior = np.abs(out[2:-2, 2:-2].astype(int) - rgb[2:-2, 2:-2])
    assert interior.max() <= 6


def test_odd_sizes_are_refused_for_422_and_bayer():
    with pytest.raises(ImageFormatError, match=r'cam1: yuv422 needs an even width, got 3x2'):
        image_from_buffer(bytes(12), 3, 2, 'yuv422', 6, source='cam1')
    with pytest.raises(ImageFormatError, match=r'bayer_rggb8 needs an even width and height'):
        image_from_buffer(bytes(12), 4, 3, 'bayer_rggb8', 4)


@pytest.mark.parametrize('codec, tolerance', [('png', 0), ('jpeg', 4)])
def test_compressed_round_trip(codec, tolerance):
    rgb = _smooth_rgb()
    data, fmt = compress_rgb(rgb, codec)
    assert fmt == f'rgb8; {codec} compressed bgr8'
    out = image_from_compressed(data, fmt, source='/cam0/image_raw/compressed')
    assert out.shape == rgb.shape and out.dtype == np.uint8
    assert np.abs(out.astype(int) - rgb).mean() <= tolerance


def test_compressed_gray_png_decodes_to_three_channels():
    gray = _smooth_rgb()[:, :, 1]
    ok, data = cv2.imencode('.png', gray)
    assert ok
    out = image_from_compressed(data.tobytes(), 'png', source='cam0')
    for channel in range(3):
        np.testing.assert_array_equal(out[:, :, channel], gray)


def test_compressed_errors_name_the_source():
    with pytest.raises(ImageFormatError, match=r"/cam2/c: cannot decode 5 bytes .*'jpeg'"):
        image_from_compressed(b'abcde', 'jpeg', source='/cam2/c')
    with pytest.raises(ImageFormatError, match=r'cam0: cannot decode 0 bytes'):
        image_from_compressed(b'', 'png', source='cam0')
    with pytest.raises(ImageFormatError, match=r"'16UC1; compressedDepth' is a depth image"):
        image_from_compressed(b'xx', '16UC1; compressedDepth', source='cam0')
    data, fmt = compress_rgb(_smooth_rgb(), 'png')
    with pytest.raises(ImageFormatError, match=r'cam3: image is 32x24 but camera_info says'):
        image_from_compressed(data, fmt, source='cam3', expected_size_px=(320, 240))
    with pytest.raises(ImageFormatError, match=r'codec must be one of jpeg, png'):
        compress_rgb(_smooth_rgb(), 'tiff')


def test_image_from_msg_reads_image_and_compressed_messages():
    rgb = _smooth_rgb()
    raw = image_msg(rgb, 5, 'cam0_optical_frame')
    np.testing.assert_array_equal(image_from_msg(raw, source='/cam0/image_raw'), rgb)
    png = compressed_image_msg(rgb, 5, 'cam0_optical_frame', 'png')
    np.testing.assert_array_equal(image_from_msg(png, source='/cam0/image_raw/compressed'),
                                  rgb)


def test_decoded_image_is_a_copy():
    rgb = np.zeros((2, 2, 3), np.uint8)
    msg = image_msg(rgb, 5, 'cam0')
    out = image_from_msg(msg, source='cam0')
    msg.data[:] = 9
    assert not out.any()
