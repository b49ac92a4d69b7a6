"""The per-camera input health the tracker reports: size mismatches drop a camera, a different
K is only reported, missing camera_info and silent cameras are problems, counts reset."""
from __future__ import annotations

import numpy as np

from hand_tracker_ros.geometry.rig import CameraRig
from hand_tracker_ros.sync.input_health import INFO_GRACE_S, SILENT_S, InputHealth


def _health() -> tuple[InputHealth, CameraRig]:
    rig = CameraRig.ring(2, 64, 48)
    return InputHealth(rig.cameras), rig


def test_a_camera_info_of_another_size_drops_the_camera_until_one_agrees() -> None:
    health, rig = _health()
    cam0 = rig.cameras[0]
    level, text = health.camera_info('cam0', 32, 24, cam0.K, 0.0)
    assert level == 'error' and 'says 32x24 but the rig says 64x48' in text
    assert not health.accepts('cam0') and health.accepts('cam1')
    assert health.problems(0.0)['cam0'] == text
    assert health.camera_info('cam0', 64, 48, cam0.K, 1.0) is None
    assert health.accepts('cam0') and health.mismatches == {}


def test_a_different_k_is_reported_and_the_rig_used() -> None:
    health, rig = _health()
    K = rig.cameras[1].K * np.array([[1.1, 1, 1], [1, 1.1, 1], [1, 1, 1]])
    level, text = health.camera_info('cam1', 64, 48, K, 0.0)
    assert level == 'warning' and 'K differs' in text and health.accepts('cam1')


def test_missing_camera_info_and_silent_cameras_are_problems() -> None:
    health, rig = _health()
    health.frame('cam0', 0.0)
    assert health.problems(0.0) == {}          # cam1's first frame may be a few ms behind
    for k in range(1, 12):
        health.frame('cam0', 0.1 * k)
    silent = health.problems(SILENT_S + 0.1)   # cam1 sent nothing while cam0 sent for 1.1 s
    assert set(silent) == {'cam1'} and 'no frames for more than' in silent['cam1']
    health.frame('cam1', SILENT_S + 0.1)
    health.camera_info('cam1', 64, 48, rig.cameras[1].K, 0.0)
    assert health.problems(INFO_GRACE_S / 2) == {}
    later = INFO_GRACE_S + 0.5
    for k in range(12, 26):                    # cam0 keeps sending, cam1 stopped at 1.1 s
        health.frame('cam0', 0.1 * k)
    problems = health.problems(later)
    assert 'no camera_info on cam0/camera_info' in problems['cam0']
    assert f'no frames for more than {SILENT_S:.0f} s' in problems['cam1']
    assert health.take_frame_counts() == {'cam0': 26, 'cam1': 1}
    assert health.take_frame_counts() == {'cam0': 0, 'cam1': 0}


def test_a_stream_resumed_after_a_pause_is_not_silent_while_its_first_frames_arrive() -> None:
    health, rig = _health()
    for camera in rig.cameras:
        health.camera_info(camera.name, 64, 48, camera.K, 0.0)
    for t in (0.0, 0.5, 1.0):
        health.frame('cam0', t)
        health.frame('cam1', t)
    health.frame('cam0', 60.0)                 # resumed after a pause: cam1 a few ms behind
    assert health.problems(60.0) == {}
    for k in range(1, 12):
        health.frame('cam0', 60.0 + 0.1 * k)
    assert set(health.problems(61.1)) == {'cam1'}   # cam0 sent for 1.1 s: cam1 is silent
    health.frame('cam1', 61.2)
    assert health.problems(61.2) == {}
