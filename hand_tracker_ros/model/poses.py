"""Named hand poses, each defined once (joint angles by ``PARAM_NAMES``; unnamed joints 0).

- :data:`NEUTRAL_RAD`: the model's neutral pose (``HandModel.neutral_theta``), also the tracker
  node's default ``initial_pose`` (:data:`NEUTRAL_THETA`, computed here without building the
  model, which costs seconds).
- :data:`RELAXED_DEG`: the rest pose of the synthetic motions, which the start search's
  hypotheses also take (``tracking/initialize.py``). A different, less flexed pose than the
  neutral one; merging the two would change the synthetic data and the search.
- :data:`CURLED_DEG`: fingers half closed, the other finger start of the recovery
  (``tracking/hypotheses.py``).
"""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.model.layout import FINGERS, FLEXIONS, PARAM_NAMES, Layout

# Relaxed, slightly flexed open hand (rad), our choice; inside the joint limits.
NEUTRAL_RAD: dict[str, float] = {
    'thumb_cmc_flex': 0.15, 'thumb_cmc_abd': 0.25, 'thumb_mcp_flex': 0.15, 'thumb_ip_flex': 0.15,
    **{f'{f}_{j}': v for f in ('index', 'middle', 'ring', 'pinky')
       for j, v in (('mcp_flex', 0.2), ('mcp_abd', 0.0), ('pip_flex', 0.25), ('dip_flex', 0.15))},
}

#: The neutral pose as a theta vector (P,), PARAM_NAMES order, wrist at the world origin.
NEUTRAL_THETA: tuple[float, ...] = tuple(NEUTRAL_RAD.get(name, 0.0) for name in PARAM_NAMES)

# A relaxed hand: joints slightly flexed (deg), ours.
RELAXED_DEG: dict[str, float] = {
    'thumb_cmc_flex': 5.0, 'thumb_cmc_abd': 20.0, 'thumb_mcp_flex': 10.0, 'thumb_ip_flex': 10.0,
    **{f'{f}_{j}': v for f in FINGERS for j, v in zip(FLEXIONS, (10.0, 15.0, 8.0))},
}

# Fingers half closed (deg), ours: halfway between RELAXED_DEG and a fist.
CURLED_DEG: dict[str, float] = {
    'thumb_cmc_flex': 10.0, 'thumb_cmc_abd': 30.0, 'thumb_mcp_flex': 30.0, 'thumb_ip_flex': 30.0,
    **{f'{f}_{j}': v for f in FINGERS for j, v in zip(FLEXIONS, (45.0, 55.0, 30.0))},
}

# A fist with the thumb outside (deg), ours: the synthetic fist motions' closed pose.
FIST_DEG: dict[str, float] = {
    'thumb_cmc_flex': 10.0, 'thumb_cmc_abd': 30.0, 'thumb_mcp_flex': 20.0, 'thumb_ip_flex': 10.0,
    **{f'{f}_{j}': v for f in FINGERS for j, v in zip(FLEXIONS, (75.0, 90.0, 45.0))},
}


def with_joints_deg(degrees: Mapping[str, float], theta: FloatArray | None = None
                    ) -> FloatArray:
    """A copy of ``theta`` (P,) (zeros by default) with the named joints set to ``degrees``
    (deg; keys are ``PARAM_NAMES``)."""
    out = np.zeros(Layout.P) if theta is None else np.array(theta, np.float64)
    for name, deg in degrees.items():
        out[Layout.index(name)] = np.deg2rad(deg)
    return out
