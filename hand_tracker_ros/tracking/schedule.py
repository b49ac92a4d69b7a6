"""Coarse-to-fine correspondence rounds of one frame.

Ballan's code runs 10 coarse rounds (distal finger joints frozen) then 20 full rounds, each a
Levenberg-Marquardt call of up to 10 iterations with correspondences and collision pairs
re-found before it, and uses optical flow only in the first 25 % of the rounds (it guides the
initial jump; edges and salient points refine). That is 300 LM iterations per frame, far over
a real-time budget; with a warm start from the previous frame a few rounds of a few
iterations keep most of the accuracy (the evaluation reports the trade-off).

The default, 1 coarse + 2 full rounds of 4 iterations, was chosen on a validation seed of the
benchmark (``--seed 1``, the full method, mean 3D joint error): 2.37 mm, against 2.22 mm
for 1+3x4 at one more round's cost, 2.65 mm for 0+3x4, and 8.49 mm for 0+2x4, which loses
the random sequence (19.9 mm, 89 failed frames); 0+2x6 recovers it only partly (3.88 mm).
Three rounds are the fewest that keep every sequence tracked.

References: docs/references.md.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hand_tracker_ros._typing import BoolArray
from hand_tracker_ros.config import param
from hand_tracker_ros.model.layout import Layout


@dataclass(frozen=True)
class ScheduleConfig:
    """Rounds of one frame."""

    coarse_rounds: int = param(1, 'rounds with the distal finger joints frozen (Ballan: 10)',
                               low=0, high=100)
    full_rounds: int = param(2, 'rounds with every DOF free (Ballan: 20)', low=1, high=100)
    iterations: int = param(4, 'LM iterations per round (Ballan: 10)', low=1, high=100)
    flow_fraction: float = param(0.25, 'fraction of the rounds that use optical flow',
                                 low=0.0, high=1.0)


@dataclass(frozen=True)
class Round:
    """One correspondence round."""

    free: BoolArray      # (P,) parameters the LM may change
    use_flow: bool


def rounds(config: ScheduleConfig) -> list[Round]:
    """The rounds of one frame, coarse first."""
    total = config.coarse_rounds + config.full_rounds
    n_flow = int(np.ceil(config.flow_fraction * total))
    coarse = ~Layout.distal
    everything = np.ones(Layout.P, bool)
    return [Round(coarse if i < config.coarse_rounds else everything, i < n_flow)
            for i in range(total)]


# One round with every parameter free and no flow: enough to rank start hypotheses.
QUICK: tuple[Round, ...] = (Round(np.ones(Layout.P, bool), use_flow=False),)
