from __future__ import annotations

import numpy as np
import pytest

from hand_tracker_ros.errors import ImageFormatError
from hand_tracker_ros.vision.image import check_rgb, clip_roi, image_from_buffer, to_gray


def _rgb(rng: np.random.Generator, h: int = 5, w: int = 7) -> np.ndarray:
    return rng.integers(0, 256, (h, w, 3), dtype=np.uint8)


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
        image_from_buffer(values.tobytes(), 4, 1, '32FC1', 16, camera_name='cam2')


def test_errors_name_the_problem(rng):
    data = _rgb(rng).tobytes()
    with pytest.raises(ImageFormatError, match=r"unsupported encoding 'yuv422'"):
        image_from_buffer(data, 7, 5, 'yuv422', 21)
    with pytest.raises(ImageFormatError, match=r'step 20 is smaller than .* = 21 for rgb8'):
        image_from_buffer(data, 7, 5, 'rgb8', 20)
    with pytest.raises(ImageFormatError, match=r'buffer holds 105 bytes but .* = 110'):
        image_from_buffer(data, 7, 5, 'rgb8', 22)
    with pytest.raises(ImageFormatError, match=r'size must be positive, got 0x5'):
        image_from_buffer(b'', 0, 5, 'rgb8', 0)
    with pytest.raises(ImageFormatError,
                       match=r'cam1: image is 7x5 but camera_info says 320x240'):
        image_from_buffer(data, 7, 5, 'rgb8', 21, camera_name='cam1',
                          expected_size_px=(320, 240))


def test_check_rgb_and_to_gray(rng):
    rgb = _rgb(rng)
    check_rgb('cam0', rgb, size_px=(7, 5))
    with pytest.raises(ImageFormatError, match=r'cam0: expected an \(H, W, 3\) uint8 RGB'):
        check_rgb('cam0', rgb.astype(np.float32))
    with pytest.raises(ImageFormatError, match=r'cam0: image is 7x5 but camera_info says 8x5'):
        check_rgb('cam0', rgb, size_px=(8, 5))
    gray = to_gray(rgb)
    expected = rgb.astype(np.float64) @ np.array([0.299, 0.587, 0.114])
    assert gray.shape == (5, 7)
    assert np.max(np.abs(gray - expected)) <= 1.0


def test_clip_roi():
    assert clip_roi('cam0', None, 320, 240) == (0, 0, 320, 240)
    assert clip_roi('cam0', (-10, 5, 100, 300), 320, 240) == (0, 5, 100, 240)
    with pytest.raises(ImageFormatError, match=r'cam0: roi_px must be \(u0, v0, u1, v1\)'):
        clip_roi('cam0', (1, 2, 3), 320, 240)
    with pytest.raises(ImageFormatError, match=r'roi_px \(5, 5, 5, 9\) does not overlap'):
        clip_roi('cam0', (5, 5, 5, 9), 320, 240)
