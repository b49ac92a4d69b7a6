"""Tests of CameraRig: YAML/mapping round trip, error messages, example config, ring rig."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from hand_tracker_ros.errors import CalibrationError
from hand_tracker_ros.geometry.camera import PinholeCamera
from hand_tracker_ros.geometry.rig import CameraRig

EXAMPLE = Path(__file__).resolve().parents[2] / 'config' / 'rig_example.yaml'


def _mixed_rig() -> CameraRig:
    ring = CameraRig.ring(3, 320, 240, seed=4)
    rational = np.array([0.3, -0.1, 0.001, 0.0005, 0.02, 0.35, -0.08, 0.03])
    cams = [PinholeCamera(c.name, c.width, c.height, c.K, d, c.T_cam_world)
            for c, d in zip(ring.cameras, (np.array([-0.1, 0.05, 1e-3, -2e-3, 0.01]),
                                           rational, np.zeros(5)))]
    return CameraRig(tuple(cams), world_frame='table')


def _assert_same(a: CameraRig, b: CameraRig) -> None:
    assert a.names == b.names and a.world_frame == b.world_frame
    for ca, cb in zip(a.cameras, b.cameras):
        assert (ca.width, ca.height) == (cb.width, cb.height)
        for field in ('K', 'dist', 'T_cam_world'):
            np.testing.assert_array_equal(getattr(ca, field), getattr(cb, field))


def test_yaml_round_trip_is_exact(tmp_path):
    rig = _mixed_rig()
    rig.to_yaml(tmp_path / 'rig.yaml')
    _assert_same(CameraRig.from_yaml(tmp_path / 'rig.yaml'), rig)
    _assert_same(CameraRig.from_mapping(rig.to_mapping()), rig)
    assert rig.to_mapping()['cameras'][1]['distortion_model'] == 'rational_polynomial'


def test_example_config_loads_and_sees_the_origin():
    rig = CameraRig.from_yaml(EXAMPLE)
    assert rig.names == ('cam0', 'cam1', 'cam2', 'cam3')
    for cam in rig:
        assert (cam.width, cam.height) == (320, 240)
        assert cam.distortion_model == 'plumb_bob' and np.any(cam.dist != 0)
        uv, depth = cam.project(np.zeros((1, 3)))
        assert depth[0] > 0.3
        np.testing.assert_allclose(uv[0], (160.0, 120.0), atol=3.0)


def test_lookup_by_name_and_index():
    rig = CameraRig.ring(3)
    assert rig['cam2'] is rig.cameras[2] and rig[0].name == 'cam0' and len(rig) == 3
    with pytest.raises(KeyError, match="no camera named 'cam7'"):
        rig['cam7']


def _entries() -> dict:
    return CameraRig.ring(3).to_mapping()


def _without(index: int, field: str) -> dict:
    data = _entries()
    del data['cameras'][index][field]
    return data


def _with(index: int, field: str, value: object) -> dict:
    data = _entries()
    data['cameras'][index][field] = value
    return data


@pytest.mark.parametrize(('data', 'pattern'), [
    (_without(2, 'K'), 'cam2: missing field `K`'),
    (_without(0, 'name'), 'camera 0: missing field `name`'),
    (_without(1, 'T_cam_world'), 'cam1: missing field `T_cam_world`'),
    (_with(1, 'T_cam_world', [0.0] * 12), 'cam1: `T_cam_world` must have 16 numbers, got 12'),
    (_with(0, 'K', 'fx fy'), 'cam0: `K` must be a list of 9 numbers, got str'),
    (_with(0, 'D', [0.0, 0.0, 'a', 0.0, 0.0]), 'cam0: `D` must hold only numbers'),
    (_with(2, 'D', [0.0] * 8), 'cam2: `D` must have 5 numbers, got 8'),
    (_with(1, 'distortion_model', 'fisheye'), "cam1: unsupported `distortion_model` 'fisheye'"),
    (_with(0, 'width', -3), 'cam0: `width` must be a positive integer, got -3'),
    (_with(0, 'K', [300, 0, 160, 0, 0, 120, 0, 0, 1]), 'cam0: `K` focal lengths must be'),
    (_with(2, 'T_cam_world', [2.0] + [0.0] * 4 + [1.0] + [0.0] * 4 + [1.0] + [0.0] * 4 + [1.0]),
     'cam2: `T_cam_world` is not a rigid transform'),
    (_with(0, 'focal', 3.0), 'cam0: unknown field `focal`'),
    (_with(1, 'name', 'cam0'), r"duplicate camera name\(s\) \['cam0'\]"),
    ({'world_frame': 'world'}, 'rig: missing field `cameras`'),
    ({'cameras': []}, 'rig: `cameras` must be a non-empty list'),
    ({'cameras': ['cam0']}, 'camera 0: must be a mapping, got str'),
])
def test_bad_fields_name_camera_and_field(data, pattern):
    with pytest.raises(CalibrationError, match=pattern):
        CameraRig.from_mapping(data)


def test_yaml_errors_name_the_file(tmp_path):
    path = tmp_path / 'rig.yaml'
    path.write_text(yaml.safe_dump(_without(2, 'K')), encoding='utf-8')
    with pytest.raises(CalibrationError, match=r'rig\.yaml: cam2: missing field `K`'):
        CameraRig.from_yaml(path)
    path.write_text('cameras: [1, 2', encoding='utf-8')
    with pytest.raises(CalibrationError, match='is not valid YAML'):
        CameraRig.from_yaml(path)
    with pytest.raises(CalibrationError, match='cannot read rig file .*missing.yaml'):
        CameraRig.from_yaml(tmp_path / 'missing.yaml')


@pytest.mark.parametrize('n', range(1, 9))
def test_ring_sees_a_hand_sized_volume_from_distinct_sides(n):
    rig = CameraRig.ring(n, 320, 240)
    assert len(rig) == n
    # A ball of radius 11 cm holds a whole adult hand centred on the target.
    dirs = np.random.default_rng(0).normal(size=(200, 3))
    ball = 0.11 * dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
    for cam in rig:
        uv, depth = cam.project(np.vstack([np.zeros(3), ball]))
        np.testing.assert_allclose(uv[0], (159.5, 119.5), atol=1e-9)
        assert (depth > 0.2).all()
        assert ((uv >= 0) & (uv <= (319, 239))).all(), cam.name
        elevation = np.degrees(np.arcsin(cam.center_world[2] / 0.45))
        assert 14.9 < elevation < 45.1
    centres = np.array([c.center_world for c in rig])
    gaps = np.linalg.norm(centres[:, None] - centres[None], axis=2)
    assert n == 1 or gaps[~np.eye(n, dtype=bool)].min() > 0.2


def test_ring_seed_jitter_is_deterministic_and_bounded():
    a, b, c = CameraRig.ring(4, seed=1), CameraRig.ring(4, seed=1), CameraRig.ring(4, seed=2)
    _assert_same(a, b)
    assert not np.allclose(a[0].T_cam_world, c[0].T_cam_world)
    for cam in a:
        assert 0.45 * 0.9 - 1e-9 <= np.linalg.norm(cam.center_world) <= 0.45 * 1.1 + 1e-9


@pytest.mark.parametrize('n', [0, 9])
def test_ring_rejects_bad_camera_count(n):
    with pytest.raises(CalibrationError, match=r'`n_cameras` must be in \[1, 8\]'):
        CameraRig.ring(n)
