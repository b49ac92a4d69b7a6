from __future__ import annotations

import dataclasses
import types

import numpy as np
import pytest

from hand_tracker_ros.bags import convert
from hand_tracker_ros.errors import ImageFormatError, ShapeError

STAMP_NS = 1_700_000_001_999_999_999


def test_header_stamp_round_trip_is_exact_in_ns():
    header = convert.header_msg(STAMP_NS, 'cam0')
    assert (header.stamp.sec, header.stamp.nanosec) == (1_700_000_001, 999_999_999)
    assert convert.stamp_ns_of(header) == STAMP_NS


def test_negative_stamp_is_refused():
    with pytest.raises(ValueError, match='stamp_ns'):
        convert.header_msg(-1, 'cam0')


def test_rgb8_image_message_layout():
    rgb = np.random.default_rng(0).integers(0, 256, (4, 5, 3), dtype=np.uint8)
    msg = convert.image_msg(rgb, STAMP_NS, 'cam0')
    assert (msg.encoding, msg.step, msg.width, msg.height) == ('rgb8', 15, 5, 4)
    np.testing.assert_array_equal(np.asarray(msg.data).reshape(4, 5, 3), rgb)


def test_compressed_image_message_fields():
    rgb = np.zeros((4, 6, 3), np.uint8)
    msg = convert.compressed_image_msg(rgb, STAMP_NS, 'cam0', 'jpeg')
    assert msg.format == 'rgb8; jpeg compressed bgr8'
    assert bytes(msg.data[:2]) == b'\xff\xd8'  # JPEG start-of-image marker
    assert convert.stamp_ns_of(msg.header) == STAMP_NS


@pytest.mark.parametrize('bad', [np.zeros((2, 2), np.uint8), np.zeros((2, 2, 3), np.float32)])
def test_image_msg_refuses_non_rgb8_arrays(bad):
    with pytest.raises(ImageFormatError, match=r'\(H, W, 3\) uint8'):
        convert.image_msg(bad, STAMP_NS, 'cam0')


def test_camera_info_round_trip_and_projection_matrix(samples):
    info = samples.camera_info(STAMP_NS)
    msg = convert.camera_info_msg(info)
    np.testing.assert_array_equal(np.reshape(msg.p, (3, 4))[:, :3], info.K)
    np.testing.assert_array_equal(np.reshape(msg.r, (3, 3)), np.eye(3))
    back = convert.camera_info_from_msg(msg)
    np.testing.assert_array_equal(back.K, info.K)
    np.testing.assert_array_equal(back.D, info.D)
    assert (back.width, back.height, back.distortion_model, back.frame_id, back.stamp_ns) == (
        7, 6, 'plumb_bob', 'cam0_optical', STAMP_NS)


def test_camera_info_checks_k(samples):
    info = samples.camera_info(STAMP_NS)
    bad = convert.CameraInfoValues(**{**{f: getattr(info, f) for f in info.__slots__},
                                      'K': np.eye(4)})
    with pytest.raises(ShapeError, match=r'`K` must be \(3, 3\), got \(4, 4\)'):
        convert.camera_info_msg(bad)


def test_joint_state_round_trip():
    msg = convert.joint_state_msg(STAMP_NS, ['a', 'b'], np.array([0.5, -1.25]))
    stamp, names, positions = convert.joint_state_from_msg(msg)
    assert (stamp, names) == (STAMP_NS, ('a', 'b'))
    np.testing.assert_array_equal(positions, [0.5, -1.25])


def test_joint_state_length_mismatch():
    with pytest.raises(ShapeError, match='positions'):
        convert.joint_state_msg(STAMP_NS, ['a', 'b'], np.zeros(3))


def test_hand_state_round_trip(samples):
    state = samples.hand_state(STAMP_NS, 2)
    back = convert.hand_state_from_msg(convert.hand_state_msg(state))
    for name in state.__slots__:
        want, got = getattr(state, name), getattr(back, name)
        if name == 'processing_time_s':
            assert got == pytest.approx(want, rel=1e-7)  # float32 in the message
        else:
            np.testing.assert_array_equal(got, want, err_msg=name)


def test_a_hand_states_shape_is_the_shape_it_carries(samples):
    from hand_tracker_ros.model.shape import SHAPE_NAMES, HandShape

    shape = HandShape(scale=1.07, radius_scale=0.95)
    state = dataclasses.replace(samples.hand_state(STAMP_NS, 2), shape_names=SHAPE_NAMES,
                                shape_parameters=shape.to_vector())
    back = convert.hand_state_from_msg(convert.hand_state_msg(state))
    assert back.shape == state.shape == shape


def test_a_hand_state_recorded_before_the_confidence_field_reads_as_nan(samples):
    msg = convert.hand_state_msg(samples.hand_state(STAMP_NS, 0))
    old = types.SimpleNamespace(**{f.name: getattr(msg, f.name) for f in dataclasses.fields(msg)
                                   if f.name != 'confidence'})
    back = convert.hand_state_from_msg(old)
    assert np.isnan(back.confidence) and back.iterations == 7


def test_hand_state_checks_fingertips(samples):
    state = samples.hand_state(STAMP_NS, 0)
    fields = {f: getattr(state, f) for f in state.__slots__}
    with pytest.raises(ShapeError, match='fingertips_m'):
        convert.hand_state_msg(convert.HandStateValues(**{**fields,
                                                          'fingertips_m': np.zeros((4, 3))}))


def test_salient_points_round_trip(samples):
    points = samples.salient(STAMP_NS, 1)
    back = convert.salient_points_from_msg(convert.salient_points_msg(points))
    for name in points.__slots__:
        np.testing.assert_array_equal(getattr(back, name), getattr(points, name), err_msg=name)
    assert back.label.dtype == np.int64


def test_empty_salient_points_keep_their_shapes(samples):
    empty = convert.SalientPointsValues(
        stamp_ns=STAMP_NS, frame_id='c', camera_name='cam0', width=7, height=6,
        uv_px=np.zeros((0, 2)), score=np.zeros(0), label=np.zeros(0, np.int64))
    back = convert.salient_points_from_msg(convert.salient_points_msg(empty))
    assert back.uv_px.shape == (0, 2) and back.score.shape == (0,)
