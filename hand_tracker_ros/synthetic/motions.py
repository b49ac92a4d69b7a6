"""Scripted hand motions with exact ground truth: pose trajectories ``theta(t)``.

A motion is a list of keyframes (time in s, named joint angles in degrees, optional wrist
position and rotation) interpolated with the C1 smoothstep ``s(u) = 3u^2 - 2u^3`` between
consecutive keyframes, so velocities vanish at keyframes and stay continuous. Unnamed joints
keep the neutral pose. Every pose is clipped to the model's joint limits.

Scene convention (matching ``CameraRig.ring``, world z up, cameras around the origin): the
hand is held like a handshake, fingers along world +y and the palm facing world -x
(``hand_ry = -90 deg``), with the wrist placed so that the middle of the hand is near the
world origin.

Motions (names accepted by :func:`trajectory`):

- ``tapping``: fingers tap one after the other (index to pinky), then the thumb;
- ``fist``: open hand -> fist (thumb outside) -> open, repeatedly;
- ``pinch``: thumb and index tips meet and part;
- ``grasp``: a cylindrical power grasp closes and opens;
- ``wrist``: pronation/supination and flexion of the wrist while the hand translates;
- ``random``: smooth random motion of every joint within 80 % of its limits, plus slow
  global motion, deterministic per seed. Key poses (and the midpoints between consecutive
  ones) whose mesh self-intersects between non-adjacent parts are redrawn, so the ground
  truth is free of interpenetration;
- ``calibration`` (not in ``MOTIONS``, the benchmark and detector-training set): the short
  motion the README asks of a user before ``hand-tracker calibrate``, every 3 s: spread the
  fingers, make a fist, open the hand and turn it one way, then the other.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.errors import ConfigError
from hand_tracker_ros.geometry.triangle_pairs import face_parts, intersecting_pairs
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.layout import FINGERS, FLEXIONS, PARAM_NAMES, Layout
from hand_tracker_ros.model.poses import FIST_DEG, RELAXED_DEG, with_joints_deg
from hand_tracker_ros.model.skeleton import joint_limits

MOTIONS = ('tapping', 'fist', 'pinch', 'grasp', 'wrist', 'random')
ALL_MOTIONS = (*MOTIONS, 'calibration')

# Wrist placement and base orientation of the handshake pose (see the module docstring).
BASE_TRANSLATION_M = (0.0, -0.085, 0.0)
BASE_ROTATION_DEG = {'hand_rz': 0.0, 'hand_ry': -90.0, 'hand_rx': 0.0}


@dataclass(frozen=True)
class Keyframe:
    """One key pose: joint angles (deg) and wrist offset (m) relative to the base pose."""

    time_s: float
    joints_deg: Mapping[str, float] = field(default_factory=dict)
    offset_m: tuple[float, float, float] = (0.0, 0.0, 0.0)


def _flexed(fingers: Sequence[str], mcp: float, pip: float, dip: float) -> dict[str, float]:
    return {f'{f}_{j}': v for f in fingers for j, v in zip(FLEXIONS, (mcp, pip, dip))}


def _cycle(poses: Sequence[Mapping[str, float]], period_s: float, duration_s: float
           ) -> list[Keyframe]:
    """Visit ``poses`` in turn, one every ``period_s``, until ``duration_s``."""
    n = int(np.ceil(duration_s / period_s)) + 1
    return [Keyframe(k * period_s, poses[k % len(poses)]) for k in range(n)]


def _tapping(duration_s: float) -> list[Keyframe]:
    taps = [_flexed([f], 60.0, 70.0, 35.0) for f in FINGERS]
    thumb = {'thumb_cmc_flex': 35.0, 'thumb_mcp_flex': 40.0, 'thumb_ip_flex': 50.0}
    poses = [p for tap in [*taps, thumb] for p in ({}, tap)]
    return _cycle(poses, 0.25, duration_s)


def _fist(duration_s: float) -> list[Keyframe]:
    return _cycle([{}, FIST_DEG], 0.8, duration_s)


def _pinch(duration_s: float) -> list[Keyframe]:
    pinch = {'thumb_cmc_flex': 30.0, 'thumb_cmc_abd': 45.0, 'thumb_mcp_flex': 25.0,
             'thumb_ip_flex': 20.0, **_flexed(['index'], 45.0, 50.0, 25.0),
             **_flexed(['middle', 'ring', 'pinky'], 25.0, 30.0, 15.0)}
    return _cycle([{}, pinch], 0.7, duration_s)


def _grasp(duration_s: float) -> list[Keyframe]:
    grasp = {**_flexed(FINGERS, 50.0, 65.0, 35.0), 'thumb_cmc_flex': 25.0,
             'thumb_cmc_abd': 55.0, 'thumb_mcp_flex': 15.0, 'thumb_ip_flex': 15.0}
    return _cycle([{}, grasp], 0.9, duration_s)


def _wrist(duration_s: float) -> list[Keyframe]:
    poses = [({}, (0.0, 0.0, 0.0)),
             ({'hand_ry': -40.0, 'hand_rx': 20.0}, (0.03, 0.02, 0.02)),
             ({'hand_ry': -130.0, 'hand_rx': -15.0}, (-0.03, -0.02, 0.04)),
             ({'hand_ry': -70.0, 'hand_rz': 15.0}, (0.0, 0.03, -0.02))]
    n = int(np.ceil(duration_s / 0.8)) + 1
    return [Keyframe(k * 0.8, *poses[k % len(poses)]) for k in range(n)]


def _calibration(duration_s: float) -> list[Keyframe]:
    straight = _flexed(FINGERS, 0.0, 0.0, 0.0)
    spread = {**straight, 'index_mcp_abd': 12.0, 'ring_mcp_abd': -10.0,
              'pinky_mcp_abd': -15.0, 'thumb_cmc_abd': 60.0, 'thumb_cmc_flex': -10.0,
              'thumb_mcp_flex': 0.0, 'thumb_ip_flex': 0.0}
    poses = [{}, spread, FIST_DEG, {**straight, 'hand_ry': -40.0, 'hand_rx': 20.0},
             {**straight, 'hand_ry': -140.0, 'hand_rx': -20.0}]
    return _cycle(poses, 0.6, duration_s)


def _collides(model: HandModel, theta: FloatArray) -> bool:
    vertices = model.pose(theta, jacobian=False).vertices_m
    parts = face_parts(model.faces, model.vertex_part)
    return len(intersecting_pairs(vertices, model.faces, parts, model.adjacent_parts)) > 0


def _random(duration_s: float, seed: int, model: HandModel) -> list[Keyframe]:
    rng = np.random.default_rng(seed)
    lower, upper = joint_limits()
    mid, half = 0.5 * (lower + upper), 0.4 * (upper - lower)  # 80 % of each range
    times = np.cumsum(np.r_[0.0, rng.uniform(0.4, 0.8, int(duration_s / 0.4) + 2)])
    frames: list[Keyframe] = []
    for t in times:
        for _ in range(200):
            angles = np.rad2deg(mid + half * rng.uniform(-1.0, 1.0, len(PARAM_NAMES)))
            joints = {n: float(a) for n, a in zip(PARAM_NAMES[6:], angles[6:])}
            joints |= {'hand_ry': float(BASE_ROTATION_DEG['hand_ry'] + rng.uniform(-40, 40)),
                       'hand_rx': float(rng.uniform(-25, 25)),
                       'hand_rz': float(rng.uniform(-15, 15))}
            frame = Keyframe(float(t), joints, tuple(rng.uniform(-0.03, 0.03, 3)))
            theta = keyframe_theta(frame)
            middle = None if not frames else 0.5 * (theta + keyframe_theta(frames[-1]))
            if not _collides(model, theta) and (middle is None or not _collides(model, middle)):
                break
        frames.append(frame)
    return frames


def keyframes(name: str, duration_s: float, seed: int = 0,
              model: HandModel | None = None) -> list[Keyframe]:
    """Keyframes of motion ``name`` covering ``[0, duration_s]``.

    ``model`` (default: the default hand) is the hand whose self-intersections the random
    motion avoids.
    """
    builders = {'tapping': _tapping, 'fist': _fist, 'pinch': _pinch, 'grasp': _grasp,
                'wrist': _wrist, 'calibration': _calibration}
    if name == 'random':
        return _random(duration_s, seed, model if model is not None else HandModel.build())
    if name not in builders:
        msg = f'unknown motion {name!r}; known: {", ".join(ALL_MOTIONS)}'
        raise ConfigError(msg)
    return builders[name](duration_s)


def keyframe_theta(frame: Keyframe) -> FloatArray:
    """Full pose vector (P,) of one keyframe: base pose, relaxed hand, then the keyframe."""
    theta = with_joints_deg({**BASE_ROTATION_DEG, **RELAXED_DEG, **frame.joints_deg})
    theta[Layout.translation] = np.add(BASE_TRANSLATION_M, frame.offset_m)
    lower, upper = joint_limits()
    return np.clip(theta, lower, upper)


def trajectory(name: str, n_frames: int, fps: float, *, seed: int = 0,
               model: HandModel | None = None) -> FloatArray:
    """Pose of every frame of motion ``name`` (``model``: see :func:`keyframes`).

    Returns
    -------
    thetas : (T, P) float64
        ``thetas[k]`` is the pose at time ``k / fps`` (m for translations, rad otherwise).
    """
    if n_frames < 1 or fps <= 0.0:
        msg = f'need n_frames >= 1 and fps > 0, got {n_frames}, {fps}'
        raise ConfigError(msg)
    frames = keyframes(name, n_frames / fps, seed, model)
    key_t = np.array([f.time_s for f in frames])
    key_theta = np.stack([keyframe_theta(f) for f in frames])
    t = np.arange(n_frames) / fps
    k = np.clip(np.searchsorted(key_t, t, side='right') - 1, 0, len(frames) - 2)
    u = np.clip((t - key_t[k]) / (key_t[k + 1] - key_t[k]), 0.0, 1.0)
    s = (3.0 * u ** 2 - 2.0 * u ** 3)[:, None]
    return (1.0 - s) * key_theta[k] + s * key_theta[k + 1]
