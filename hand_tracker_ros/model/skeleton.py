"""Skeleton tables of the hand model: names, parents, rest geometry, radii and joint limits.

Hand frame (the palm bone's frame, right hand): origin at the wrist joint centre,
+y from the wrist to the middle-finger MCP, +x towards the thumb side (radial), and
+z = x cross y, the palm normal pointing OUT OF THE PALM (volar side). Finger flexion is a
positive rotation about the bone's local +x, so it curls the finger towards +z (the palm);
abduction is a rotation about the local -z, positive towards the thumb side for the long
fingers, and out of the palm plane towards the volar side (palmar abduction) for the thumb.

Bone frames: every finger bone's origin is its proximal joint centre and its local +y runs
along the bone to the next joint, which sits at ``(0, length, 0)``. The rest (bind) pose,
``theta = 0``, is a flat hand with slightly spread fingers and the thumb rolled and spread
so that its flexion axis is roughly the palm normal; the rest rotations are
``Rz(-splay)`` for the long fingers and ``Rz(-45 deg) Rx(8 deg) Ry(-80 deg)`` for the thumb
(angles chosen by us to look like a relaxed open hand; not from a paper).

Bones (B = 16): 'palm', then per finger three segments (thumb: metacarpal, proximal,
distal; others: proximal, middle, distal). Bone ``1 + 3 i + l`` is segment ``l`` of finger
``i`` in FINGER_NAMES order.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.geometry.rotations import rot_x, rot_y, rot_z
from hand_tracker_ros.model.layout import PARAM_NAMES
from hand_tracker_ros.model.shape import HandShape

FINGER_NAMES = ('thumb', 'index', 'middle', 'ring', 'pinky')
_SEGMENTS = {'thumb': ('metacarpal', 'proximal', 'distal')}
_JOINTS = {'thumb': ('cmc', 'mcp', 'ip', 'tip')}

KEYPOINT_NAMES: tuple[str, ...] = ('wrist', *(
    f'{f}_{j}' for f in FINGER_NAMES for j in _JOINTS.get(f, ('mcp', 'pip', 'dip', 'tip'))))

BONE_NAMES: tuple[str, ...] = ('palm', *(
    f'{f}_{s}' for f in FINGER_NAMES
    for s in _SEGMENTS.get(f, ('proximal', 'middle', 'distal'))))
BONE_PARENTS: tuple[int, ...] = (-1, *(0 if lvl == 0 else 1 + 3 * i + lvl - 1
                                       for i in range(5) for lvl in range(3)))
B = len(BONE_NAMES)

# Keypoints: wrist = palm origin; the first three keypoints of finger i are the origins of its
# bones, the tip is (0, length, 0) in its distal bone.
KEYPOINT_BONES: tuple[int, ...] = (0, *(1 + 3 * i + min(j, 2) for i in range(5)
                                        for j in range(4)))

# Base joint (thumb CMC, finger MCP) positions in the hand frame: x as a fraction of
# palm_width_m, y as a fraction of palm_length_m, z in metres (times scale). Chosen by us so
# that the MCP row arches like a real hand (pinky MCP lowest); middle MCP is (0, L, 0) by the
# definition of the hand frame.
_BASE_FRACTIONS = np.array([[0.36, 0.22], [0.36, 0.96], [0.0, 1.0], [-0.32, 0.95],
                            [-0.64, 0.87]])
_BASE_Z_M = np.array([0.010, 0.0, 0.0, 0.0, 0.0])

# Rest splay towards the thumb side, deg (ours: wide enough that the fingers do not touch in
# the rest mesh, so the mesh has no webs beyond the knuckles).
_SPLAY_DEG = np.array([45.0, 10.0, 0.0, -10.0, -20.0])

# Sphere radii, m, at (base joint, 2nd joint, 3rd joint, tip) per finger, for a hand of the
# default size. Our estimates from typical adult finger breadths (index PIP breadth about
# 19-21 mm); the tip sphere is tangent to the fingertip.
FINGER_RADII_M = np.array([
    [0.0125, 0.0105, 0.0095, 0.0085],
    [0.0100, 0.0090, 0.0080, 0.0072],
    [0.0102, 0.0092, 0.0082, 0.0074],
    [0.0098, 0.0088, 0.0078, 0.0070],
    [0.0088, 0.0078, 0.0070, 0.0064],
])
# Two wrist spheres (radial, ulnar) spanning the heel of the palm: (x frac, y frac, r_m).
_WRIST_SPHERES = np.array([[0.36, 0.07, 0.0135], [-0.40, 0.07, 0.0125]])

# Joint limits, deg, (lower, upper). Sources, honestly:
# - long fingers: MCP flexion 90, PIP 110, DIP 90 and MCP abduction +-15 are the static
#   constraints of Lin, Wu & Huang 2000 ("Modeling the constraints of human hand motion");
#   MCP hyperextension 30 and DIP hyperextension 10 are our choice, inside the AAOS normative
#   active ranges (Greene & Heckman 1994: MCP extension up to 45, DIP extension 10).
# - thumb: MCP flexion 0..50 (we allow -10) and IP -20..80 follow the AAOS norms; the CMC
#   is not a clean pair of hinges, its two ranges are our estimates chosen to allow
#   opposition and full palmar abduction (AAOS palmar abduction 70).
_LIMITS_DEG = {
    'thumb_cmc_flex': (-30.0, 50.0), 'thumb_cmc_abd': (-15.0, 70.0),
    'thumb_mcp_flex': (-10.0, 55.0), 'thumb_ip_flex': (-20.0, 80.0),
    **{f'{f}_{j}': lim for f in FINGER_NAMES[1:] for j, lim in (
        ('mcp_flex', (-30.0, 90.0)), ('mcp_abd', (-15.0, 15.0)),
        ('pip_flex', (0.0, 110.0)), ('dip_flex', (-10.0, 90.0)))},
}
# Global DOF: wide bounds that only keep the optimizer finite.
GLOBAL_TRANSLATION_LIMIT_M = 5.0
GLOBAL_ROTATION_LIMIT_RAD = 2.0 * np.pi


def joint_limits() -> tuple[FloatArray, FloatArray]:
    """Lower and upper bounds (P,) float64 in PARAM_NAMES order (m for translation, else rad)."""
    lo, hi = np.zeros(len(PARAM_NAMES)), np.zeros(len(PARAM_NAMES))
    for k, name in enumerate(PARAM_NAMES):
        if k < 3:
            lo[k], hi[k] = -GLOBAL_TRANSLATION_LIMIT_M, GLOBAL_TRANSLATION_LIMIT_M
        elif k < 6:
            lo[k], hi[k] = -GLOBAL_ROTATION_LIMIT_RAD, GLOBAL_ROTATION_LIMIT_RAD
        else:
            lo[k], hi[k] = np.deg2rad(_LIMITS_DEG[name])
    return lo, hi


@dataclass(frozen=True)
class RestSkeleton:
    """Rest geometry of one hand shape, in the hand frame.

    Attributes
    ----------
    base_m : (5, 3) float64
        Thumb CMC and finger MCP centres.
    lengths_m : (5, 3) float64
        Segment lengths per finger.
    rest_rot : (5, 3, 3) float64
        Rest rotation of each finger's first bone relative to the palm (later bones: I).
    finger_radii_m : (5, 4) float64
        Sphere radii at base joint, 2nd joint, 3rd joint, tip.
    wrist_m : (2, 3) float64
        Wrist sphere centres (radial, ulnar); ``wrist_radii_m`` (2,) their radii.
    """

    base_m: FloatArray
    lengths_m: FloatArray
    rest_rot: FloatArray
    finger_radii_m: FloatArray
    wrist_m: FloatArray
    wrist_radii_m: FloatArray


def rest_skeleton(shape: HandShape) -> RestSkeleton:
    """Rest geometry of ``shape`` (see :class:`RestSkeleton`)."""
    s = shape.scale
    width, length = s * shape.palm_width_m, s * shape.palm_length_m
    base = np.column_stack([_BASE_FRACTIONS[:, 0] * width, _BASE_FRACTIONS[:, 1] * length,
                            _BASE_Z_M * s])
    rest = np.array([rot_z(-np.deg2rad(a)) for a in _SPLAY_DEG])
    rest[0] = rest[0] @ rot_x(np.deg2rad(8.0)) @ rot_y(np.deg2rad(-80.0))
    radius = s * shape.radius_scale
    wrist = np.column_stack([_WRIST_SPHERES[:, 0] * width, _WRIST_SPHERES[:, 1] * length,
                             np.zeros(2)])
    return RestSkeleton(base_m=base, lengths_m=shape.finger_lengths_m(), rest_rot=rest,
                        finger_radii_m=radius * FINGER_RADII_M, wrist_m=wrist,
                        wrist_radii_m=radius * _WRIST_SPHERES[:, 2])
