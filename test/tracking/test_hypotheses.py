"""Start hypotheses: constant-velocity prediction, hands turned about their own axes, other
fingers, swapped neighbours."""
from __future__ import annotations

import numpy as np

from hand_tracker_ros.geometry.rotations import rot_y, rot_z
from hand_tracker_ros.model.layout import FINGERS, FLEXIONS, Layout
from hand_tracker_ros.tracking.hypotheses import (
    FINGER_POSES,
    TURNS,
    constant_velocity,
    finger_hypotheses,
    hand_rotation,
    swapped_fingers,
    turned,
    turned_hypotheses,
)


def _theta(model):
    theta = model.neutral_theta((0.01, -0.05, 0.02))
    theta[3:6] = (0.2, -1.3, 0.4)             # rz, ry, rx: a generic orientation
    return theta


def test_a_turn_rotates_the_hand_in_its_own_frame_about_its_centre(hand_model) -> None:
    theta = _theta(hand_model)
    centre = hand_model.pose(theta, jacobian=False).keypoints_m.mean(axis=0)
    for turn in (rot_y(np.pi), rot_y(0.5 * np.pi), rot_z(np.pi)):
        out = turned(theta, turn, hand_model)
        np.testing.assert_allclose(hand_rotation(out), hand_rotation(theta) @ turn, atol=1e-9)
        np.testing.assert_allclose(hand_model.pose(out, jacobian=False).keypoints_m.mean(axis=0),
                                   centre, atol=1e-9)
        np.testing.assert_array_equal(out[6:], theta[6:])       # the fingers do not move


def test_a_flip_about_the_finger_axis_moves_the_thumb_to_the_other_side(hand_model) -> None:
    theta = _theta(hand_model)
    flipped = turned_hypotheses(theta, hand_model)['flip_finger_axis']
    before = hand_model.pose(theta, jacobian=False).fingertips_m[0]
    after = hand_model.pose(flipped, jacobian=False).fingertips_m[0]
    assert np.linalg.norm(after - before) > 0.03
    back = turned(flipped, rot_y(np.pi), hand_model)
    np.testing.assert_allclose(hand_rotation(back), hand_rotation(theta), atol=1e-9)
    assert set(turned_hypotheses(theta, hand_model)) == set(TURNS)


def test_constant_velocity_extrapolates_and_stays_in_the_limits(hand_model) -> None:
    a, b = _theta(hand_model), _theta(hand_model)
    b[0] += 0.01
    b[10] += 0.1
    np.testing.assert_allclose(constant_velocity(np.stack([a, b]), hand_model)[[0, 10]],
                               [a[0] + 0.02, a[10] + 0.2])
    np.testing.assert_allclose(constant_velocity(np.stack([a, b]), hand_model, 2.0)[[0, 10]],
                               [a[0] + 0.03, a[10] + 0.3])         # a skipped set
    np.testing.assert_array_equal(constant_velocity(b[None], hand_model), b)
    far = b.copy()
    far[10] = hand_model.upper[10]
    past = far.copy()
    past[10] -= 0.5
    assert constant_velocity(np.stack([past, far]), hand_model)[10] == hand_model.upper[10]


def test_finger_hypotheses_keep_the_palm_and_set_every_finger_joint(hand_model) -> None:
    theta = _theta(hand_model)
    starts = finger_hypotheses(theta, hand_model)
    assert set(starts) == set(FINGER_POSES)
    wrist = hand_model.pose(theta, jacobian=False).keypoints_m[0]
    tips = []
    for name, start in starts.items():
        np.testing.assert_array_equal(start[:6], theta[:6])
        expected = np.zeros(Layout.P - 6)
        for joint, deg in FINGER_POSES[name].items():
            expected[Layout.index(joint) - 6] = np.deg2rad(deg)
        np.testing.assert_allclose(start[6:], np.clip(expected, hand_model.lower[6:],
                                                      hand_model.upper[6:]))
        posed = hand_model.pose(start, jacobian=False)
        np.testing.assert_allclose(posed.keypoints_m[0], wrist, atol=1e-12)
        tips.append(np.linalg.norm(posed.fingertips_m - wrist, axis=1))
    assert np.all(tips[1][1:] < tips[0][1:])      # curled long fingers end nearer the wrist


def test_swapped_fingers_exchange_two_neighbours_flexions_and_nothing_else(hand_model) -> None:
    theta = _theta(hand_model)
    for k, finger in enumerate(FINGERS):      # every finger flexed differently, abducted
        for j, joint in enumerate(FLEXIONS):
            theta[Layout.index(f'{finger}_{joint}')] = 0.1 + 0.2 * k + 0.05 * j
        theta[Layout.index(f'{finger}_mcp_abd')] = 0.1
    starts = swapped_fingers(theta, hand_model)
    assert set(starts) == {'swap_index_middle', 'swap_middle_ring', 'swap_ring_pinky'}
    flexion = {f: theta[[Layout.index(f'{f}_{j}') for j in FLEXIONS]] for f in FINGERS}
    for first, second in zip(FINGERS[:-1], FINGERS[1:]):
        name = f'swap_{first}_{second}'
        start = starts[name]
        changed = {Layout.index(f'{f}_{j}') for f in (first, second)
                   for j in (*FLEXIONS, 'mcp_abd')}
        kept = [i for i in range(Layout.P) if i not in changed]
        np.testing.assert_array_equal(start[kept], theta[kept])
        np.testing.assert_array_equal(start[[Layout.index(f'{first}_{j}') for j in FLEXIONS]],
                                      flexion[second])
        np.testing.assert_array_equal(start[[Layout.index(f'{second}_{j}') for j in FLEXIONS]],
                                      flexion[first])
        assert start[Layout.index(f'{first}_mcp_abd')] == start[
            Layout.index(f'{second}_mcp_abd')] == 0.0
        # Swapping again gives back the start with the two abductions at 0.
        back = swapped_fingers(start, hand_model)[name]
        np.testing.assert_array_equal(back[kept], theta[kept])
        np.testing.assert_array_equal(back[[Layout.index(f'{first}_{j}') for j in FLEXIONS]],
                                      flexion[first])
