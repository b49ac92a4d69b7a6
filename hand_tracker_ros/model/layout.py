"""The named layout of the pose vector ``theta`` (P = 26).

``PARAM_NAMES`` are at the same time the URDF joint names and the ``sensor_msgs/JointState``
names the tracker publishes, so one table serves the optimizer, the URDF and the messages.

=========  =====================================  =====  ================================
index      names                                  unit   meaning
=========  =====================================  =====  ================================
0-2        hand_tx, hand_ty, hand_tz              m      wrist position in the world
3-5        hand_rz, hand_ry, hand_rx              rad    global rotation (three hinges)
6-9        thumb_cmc_flex, thumb_cmc_abd,         rad    thumb
           thumb_mcp_flex, thumb_ip_flex
10-25      <f>_mcp_flex, <f>_mcp_abd,             rad    f in index, middle, ring, pinky
           <f>_pip_flex, <f>_dip_flex
=========  =====================================  =====  ================================

Global rotation. The three hinges act about the wrist and are chained
``R_world_hand = Ry(hand_ry) Rz(hand_rz) Rx(hand_rx)`` (outermost first; the order in the
vector differs from the chain order on purpose). Such a chain is singular only when its
*middle* angle reaches +-90 deg. The middle hinge is ``hand_rz``, the palm normal
(radial/ulnar deviation in the hand frame), which has the smallest range in ordinary motion;
forearm pronation/supination (about the finger axis +y) is the outermost hinge and wrist
flexion (+x) the innermost, so both can turn freely without approaching the singularity.
In the world frame the singular set is "fingers pointing along world +-x".
"""
from __future__ import annotations

import types

import numpy as np

from hand_tracker_ros._typing import BoolArray

FINGERS = ('index', 'middle', 'ring', 'pinky')
# The flexion joints of a long finger, base first.
FLEXIONS = ('mcp_flex', 'pip_flex', 'dip_flex')

PARAM_NAMES: tuple[str, ...] = (
    'hand_tx', 'hand_ty', 'hand_tz',
    'hand_rz', 'hand_ry', 'hand_rx',
    'thumb_cmc_flex', 'thumb_cmc_abd', 'thumb_mcp_flex', 'thumb_ip_flex',
    *(f'{f}_{j}' for f in FINGERS for j in ('mcp_flex', 'mcp_abd', 'pip_flex', 'dip_flex')),
)

P = len(PARAM_NAMES)

# Chain order of the global rotation hinges, outermost first (see the module docstring).
GLOBAL_ROTATION_CHAIN = ('hand_ry', 'hand_rz', 'hand_rx')

# Names of the DOF that the coarse rounds of coarse-to-fine LM keep frozen.
_DISTAL = ('thumb_mcp_flex', 'thumb_ip_flex',
           *(f'{f}_{j}' for f in FINGERS for j in ('pip_flex', 'dip_flex')))


def _mask(names: tuple[str, ...]) -> BoolArray:
    mask = np.zeros(P, dtype=bool)
    mask[[PARAM_NAMES.index(n) for n in names]] = True
    mask.setflags(write=False)
    return mask


class Layout:
    """Named slices and masks of the pose vector ``theta`` (P,) float64.

    Attributes
    ----------
    P : int
        Number of parameters (26).
    translation, rotation, global_, thumb, fingers : slice
        Wrist position (m), global rotation (rad), both, the thumb's 4 DOF, the 16 DOF of the
        four long fingers.
    per_finger : Mapping[str, slice] (read-only)
        The 4 DOF of each of 'thumb', 'index', 'middle', 'ring', 'pinky'.
    prismatic, revolute : (P,) bool
        Translation DOF (m) and hinge DOF (rad).
    distal : (P,) bool
        PIP, DIP, thumb MCP and IP flexion: frozen in the coarse LM rounds.
    rigid : (P,) bool
        The 6 global DOF.
    """

    P = P
    names = PARAM_NAMES
    translation = slice(0, 3)
    rotation = slice(3, 6)
    global_ = slice(0, 6)
    thumb = slice(6, 10)
    fingers = slice(10, 26)
    per_finger = types.MappingProxyType(
        {'thumb': slice(6, 10),
         **{f: slice(10 + 4 * i, 14 + 4 * i) for i, f in enumerate(FINGERS)}})
    prismatic = _mask(PARAM_NAMES[0:3])
    revolute = _mask(PARAM_NAMES[3:])
    distal = _mask(_DISTAL)
    rigid = _mask(PARAM_NAMES[0:6])

    @staticmethod
    def index(name: str) -> int:
        """Position of the parameter ``name`` in ``theta``; raises KeyError if unknown."""
        try:
            return PARAM_NAMES.index(name)
        except ValueError as err:
            msg = f'unknown pose parameter {name!r}; known: {", ".join(PARAM_NAMES)}'
            raise KeyError(msg) from err
