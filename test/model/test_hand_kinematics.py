"""Forward kinematics, keypoint/sphere Jacobians and the parameter layout."""
from __future__ import annotations

import numpy as np
import pytest

from hand_tracker_ros.geometry.rotations import rot_x, rot_y, rot_z
from hand_tracker_ros.model.kinematics import (
    MOVES,
    forward_kinematics,
    points_jacobian,
    transform_points,
)
from hand_tracker_ros.model.layout import PARAM_NAMES, Layout
from hand_tracker_ros.model.skeleton import (
    BONE_NAMES,
    FINGER_NAMES,
    KEYPOINT_BONES,
    KEYPOINT_NAMES,
    B,
)


def test_layout_names_and_masks() -> None:
    assert Layout.P == len(PARAM_NAMES) == 26
    assert len(set(PARAM_NAMES)) == 26
    assert PARAM_NAMES[Layout.translation] == ('hand_tx', 'hand_ty', 'hand_tz')
    assert PARAM_NAMES[Layout.per_finger['ring']] == (
        'ring_mcp_flex', 'ring_mcp_abd', 'ring_pip_flex', 'ring_dip_flex')
    assert np.flatnonzero(Layout.rigid).tolist() == list(range(6))
    assert np.flatnonzero(Layout.prismatic).tolist() == [0, 1, 2]
    assert not np.any(Layout.prismatic & Layout.revolute)
    distal = {PARAM_NAMES[k] for k in np.flatnonzero(Layout.distal)}
    assert distal == {'thumb_mcp_flex', 'thumb_ip_flex', *(
        f'{f}_{j}' for f in FINGER_NAMES[1:] for j in ('pip_flex', 'dip_flex'))}
    with pytest.raises(KeyError, match='unknown pose parameter'):
        Layout.index('wrist_flex')


def test_names() -> None:
    assert len(KEYPOINT_NAMES) == 21 and KEYPOINT_NAMES[:5] == (
        'wrist', 'thumb_cmc', 'thumb_mcp', 'thumb_ip', 'thumb_tip')
    assert KEYPOINT_NAMES[-1] == 'pinky_tip' and len(BONE_NAMES) == 16


def test_rest_pose_hand_frame_axes(model) -> None:
    kp = model.pose(np.zeros(26), jacobian=False).keypoints_m
    name = KEYPOINT_NAMES.index
    np.testing.assert_allclose(kp[name('wrist')], 0.0)
    middle = kp[name('middle_mcp')]
    assert middle[0] == pytest.approx(0.0) and middle[1] > 0.05   # +y wrist -> middle MCP
    assert kp[name('thumb_tip')][0] > kp[name('index_tip')][0]    # +x towards the thumb
    flexed = np.zeros(26)
    flexed[PARAM_NAMES.index('index_pip_flex')] = 1.0
    tip = model.pose(flexed, jacobian=False).keypoints_m[name('index_tip')]
    assert tip[2] > 0.01                                          # flexion curls to +z


def test_global_translation_moves_everything(model) -> None:
    theta = model.neutral_theta()
    moved = model.neutral_theta(translation_m=(0.1, -0.2, 0.3))
    a, b = model.pose(theta, jacobian=False), model.pose(moved, jacobian=False)
    np.testing.assert_allclose(b.keypoints_m - a.keypoints_m, [[0.1, -0.2, 0.3]] * 21,
                               atol=1e-12)


def test_bone_lengths_are_pose_invariant(model, random_theta) -> None:
    rng = np.random.default_rng(3)
    rest = model.pose(np.zeros(26), jacobian=False).keypoints_m
    posed = model.pose(random_theta(rng), jacobian=False).keypoints_m
    for f in range(5):
        chain = [1 + 4 * f + j for j in range(4)]
        np.testing.assert_allclose(np.linalg.norm(np.diff(posed[chain], axis=0), axis=1),
                                   np.linalg.norm(np.diff(rest[chain], axis=0), axis=1),
                                   rtol=1e-12)


@pytest.mark.parametrize('seed', [0, 1, 2])
def test_keypoint_jacobian_matches_central_difference(model, random_theta, numeric_jacobian,
                                                      seed: int) -> None:
    theta = random_theta(np.random.default_rng(seed))
    analytic = model.pose(theta).keypoints_jac
    numeric = numeric_jacobian(lambda t: model.pose(t, jacobian=False).keypoints_m, theta)
    np.testing.assert_allclose(analytic, numeric, rtol=1e-5, atol=1e-8)


def test_sphere_center_jacobian_matches_central_difference(model, random_theta,
                                                           numeric_jacobian) -> None:
    theta = random_theta(np.random.default_rng(11))
    analytic = model.pose(theta).sphere_centers_jac
    numeric = numeric_jacobian(lambda t: model.pose(t, jacobian=False).sphere_centers_m,
                               theta)
    np.testing.assert_allclose(analytic, numeric, rtol=1e-5, atol=1e-8)


def test_distal_joint_does_not_move_proximal_keypoints(model) -> None:
    jac = model.pose(model.neutral_theta()).keypoints_jac
    k = PARAM_NAMES.index('middle_dip_flex')
    moved = {KEYPOINT_NAMES[i] for i in np.flatnonzero(np.abs(jac[:, :, k]).sum(1) > 0)}
    assert moved == {'middle_tip'}


def _numpy_forward_kinematics(rest, theta):
    """The plain numpy form of the FK kernel (reference): transforms, axes, pivots."""
    def rx(a):
        return np.stack([rot_x(v) for v in np.atleast_1d(a)])

    def rz(a):
        return np.stack([rot_z(v) for v in np.atleast_1d(a)])

    ry_, rz_, rx_ = (PARAM_NAMES.index(n) for n in ('hand_ry', 'hand_rz', 'hand_rx'))
    ryz = rot_y(theta[ry_]) @ rot_z(theta[rz_])
    r_hand, t = ryz @ rot_x(theta[rx_]), theta[0:3]
    transforms = np.tile(np.eye(4), (B, 1, 1))
    transforms[0, :3, :3], transforms[0, :3, 3] = r_hand, t
    axes, pivots = np.zeros((26, 3)), np.zeros((26, 3))
    axes[:3] = np.eye(3)
    axes[ry_], axes[rz_], axes[rx_] = (0, 1, 0), rot_y(theta[ry_])[:, 2], ryz[:, 0]
    pivots[3:6] = t
    k0 = 6 + 4 * np.arange(5)
    bones = 1 + 3 * np.arange(5)[:, None] + np.arange(3)[None, :]
    r_abd = r_hand @ rest.rest_rot
    r_flex = r_abd @ rz(-theta[k0 + 1])
    rot = r_flex @ rx(theta[k0])
    pos = t + rest.base_m @ r_hand.T
    axes[k0 + 1], axes[k0] = -r_abd[:, :, 2], r_flex[:, :, 0]
    pivots[k0 + 1], pivots[k0] = pos, pos
    transforms[bones[:, 0], :3, :3], transforms[bones[:, 0], :3, 3] = rot, pos
    for lvl in (1, 2):
        pos = pos + rot[:, :, 1] * rest.lengths_m[:, lvl - 1, None]
        axes[k0 + 1 + lvl], pivots[k0 + 1 + lvl] = rot[:, :, 0], pos
        rot = rot @ rx(theta[k0 + 1 + lvl])
        transforms[bones[:, lvl], :3, :3], transforms[bones[:, lvl], :3, 3] = rot, pos
    return transforms, axes, pivots


def test_fk_kernel_matches_the_numpy_form(model, random_theta) -> None:
    for theta in (model.neutral_theta((0.01, -0.02, 0.3)),
                  random_theta(np.random.default_rng(11))):
        fk = forward_kinematics(model.rest, theta)
        ref = _numpy_forward_kinematics(model.rest, theta)
        for got, want in zip((fk.bone_transforms, fk.axes, fk.pivots), ref):
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-14)


def test_points_jacobian_kernel_matches_the_numpy_form(model, random_theta) -> None:
    """The kernel against ``np.cross`` of every hinge, masked by the bones each DOF moves."""
    theta = random_theta(np.random.default_rng(12))
    fk = forward_kinematics(model.rest, theta)
    bones = np.asarray(KEYPOINT_BONES)
    points = transform_points(fk, bones, model.keypoint_local_m)
    cols = np.cross(fk.axes[None, :, :], points[:, None, :] - fk.pivots[None, :, :])
    cols[:, :3, :] = np.eye(3)
    cols *= MOVES.T[bones][:, :, None]
    np.testing.assert_array_equal(points_jacobian(fk, bones, points),
                                  cols.transpose(0, 2, 1))
