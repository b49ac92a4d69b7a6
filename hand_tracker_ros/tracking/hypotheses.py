"""Start poses for a frame besides the previous estimate: prediction, turned hands, other
fingers and swapped neighbours.

- **Constant velocity**: ``theta_t = theta_1 + s (theta_1 - theta_0)``, clipped to the joint
  limits, from the last two accepted estimates ``theta_0, theta_1`` (stamps ``t_0, t_1``) with
  ``s = (t - t_1) / (t_1 - t_0)``: 1 for consecutive sets, 2 when a live tracker skipped one.
- **Turned**: the hand turned as a whole about its own axes (the finger axis +y and the palm
  normal +z of the hand frame, :mod:`hand_tracker_ros.model.layout`) around the centroid of
  its keypoints, so it stays where the data is. The global rotation is
  ``R = Ry(hand_ry) Rz(hand_rz) Rx(hand_rx)``; a turn by ``T`` in the hand frame is
  ``R' = R T``, split back into the three hinges with
  :func:`hand_tracker_ros.geometry.rotations.euler_xzy_from_matrix` on ``R'^T``
  (``R'^T = Rx(-rx) Rz(-rz) Ry(-ry)``). A palm flipped about the finger axis is the typical
  wrong basin of a silhouette fit: the outline barely changes while the thumb moves to the
  other side.
- **Other fingers**: the same hand (global pose) with the fingers relaxed or half closed
  (:mod:`hand_tracker_ros.model.poses`). A fit whose palm is right but whose fingers settled
  in the wrong place (folded onto the palm, or into skin-coloured clutter beside it) keeps
  most of the silhouette and rarely leaves that basin by itself.
- **Swapped neighbours**: the same hand with the flexions (MCP, PIP, DIP) of two neighbouring
  fingers exchanged and their abductions set to 0. A fit can lay one finger on its
  neighbour's image, e.g. an extended middle finger abducted onto an extended ring finger
  while its own ring finger folds out of sight behind the palm: the global pose is right, the
  silhouette is covered, the confidence stays high (0.72-0.96 on random-motion seed 11,
  28 mm off), and no whole-hand finger pose brings both fingers back. Measured offline with
  the recovery (``hand-tracker track`` conditions, mean 3D joint error, first 60 frames from
  the automatic start): random seeds 11, 7003 and 7004 went from 3.81 / 1.72 / 3.31 to
  1.89 / 1.36 / 1.97 mm, five other random seeds were unchanged to the digit; from the
  true pose (90 frames) grasp 345 went from 3.46 to 2.29 mm, grasp 342 lost its frames more
  than 15 mm off (13 % to 0 %) at a mean of 10.2 against 9.7 mm, and grasp 31, pinch, fist
  and random were unchanged. One finger toggled between relaxed and curled at a time was
  tried as well: no change on 10 of 12 sequences, 0.2-1 mm on the other two; not kept.
"""
from __future__ import annotations

import numpy as np

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.geometry.rotations import euler_xzy_from_matrix, rot_x, rot_y, rot_z
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.layout import FINGERS, FLEXIONS, Layout
from hand_tracker_ros.model.poses import CURLED_DEG, RELAXED_DEG, with_joints_deg

_RY, _RZ, _RX = (Layout.index(n) for n in ('hand_ry', 'hand_rz', 'hand_rx'))

# Turns tried by recovery (hand frame): name -> rotation matrix.
TURNS: dict[str, FloatArray] = {
    'flip_finger_axis': rot_y(np.pi),
    'quarter_finger_axis+': rot_y(0.5 * np.pi),
    'quarter_finger_axis-': rot_y(-0.5 * np.pi),
    'flip_palm_normal': rot_z(np.pi),
}


def constant_velocity(history: FloatArray, model: HandModel, steps: float = 1.0) -> FloatArray:
    """The pose ``steps`` history intervals after the last of ``history`` (K, P), oldest first,
    at constant velocity (K >= 1; with K = 1 the last pose)."""
    if history.shape[0] < 2:
        return history[-1].copy()
    return np.clip(history[-1] + steps * (history[-1] - history[-2]), model.lower, model.upper)


def hand_rotation(theta: FloatArray) -> FloatArray:
    """``R = Ry(hand_ry) Rz(hand_rz) Rx(hand_rx)`` (3, 3) of a pose."""
    return rot_y(theta[_RY]) @ rot_z(theta[_RZ]) @ rot_x(theta[_RX])


def turned(theta: FloatArray, turn: FloatArray, model: HandModel) -> FloatArray:
    """``theta`` with the hand turned by ``turn`` (3, 3, hand frame) about its keypoint
    centroid."""
    out = np.array(theta, np.float64)
    centre = model.pose(out, jacobian=False).keypoints_m.mean(axis=0)
    neg_rx, neg_rz, neg_ry = euler_xzy_from_matrix((hand_rotation(out) @ turn).T)
    out[_RY], out[_RZ], out[_RX] = -neg_ry, -neg_rz, -neg_rx
    out = np.clip(out, model.lower, model.upper)
    moved = model.pose(out, jacobian=False).keypoints_m.mean(axis=0)
    out[Layout.translation] += centre - moved
    return out


def turned_hypotheses(theta: FloatArray, model: HandModel) -> dict[str, FloatArray]:
    """Every turn of :data:`TURNS` applied to ``theta``."""
    return {name: turned(theta, turn, model) for name, turn in TURNS.items()}


# Finger starts tried by recovery: name -> joint angles (deg) of every finger DOF.
FINGER_POSES: dict[str, dict[str, float]] = {'relaxed_fingers': RELAXED_DEG,
                                              'curled_fingers': CURLED_DEG}


def finger_hypotheses(theta: FloatArray, model: HandModel) -> dict[str, FloatArray]:
    """``theta`` with its global pose and the fingers of every :data:`FINGER_POSES` entry."""
    out = {}
    for name, degrees in FINGER_POSES.items():
        start = np.array(theta, np.float64)
        start[Layout.thumb] = start[Layout.fingers] = 0.0
        out[name] = np.clip(with_joints_deg(degrees, start), model.lower, model.upper)
    return out


def swapped_fingers(theta: FloatArray, model: HandModel) -> dict[str, FloatArray]:
    """``theta`` (P,) with the flexions of two neighbouring fingers exchanged and their
    abductions set to 0, for every pair of neighbours among index to pinky (module
    docstring); name -> (P,), clipped to the joint limits. A pair with equal flexions still
    gives a start (its abductions at 0): one short fit more on a doubtful frame."""
    out = {}
    for first, second in zip(FINGERS[:-1], FINGERS[1:]):
        start = np.array(theta, np.float64)
        for joint in FLEXIONS:
            a, b = Layout.index(f'{first}_{joint}'), Layout.index(f'{second}_{joint}')
            start[a], start[b] = theta[b], theta[a]
        for finger in (first, second):
            start[Layout.index(f'{finger}_mcp_abd')] = 0.0
        out[f'swap_{first}_{second}'] = np.clip(start, model.lower, model.upper)
    return out
