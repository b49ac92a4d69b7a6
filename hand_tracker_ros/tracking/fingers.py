"""Finger-wise search: one finger at a time is put in other states and the hand refitted.

The global search (:mod:`.initialize`) starts from relaxed hands. When it ends with the palm
in place, what is left wrong is one or two fingers: on random-motion sets the palm keypoints
were within 1-4 mm of the truth in 7 of 10 searched sets while single fingertips were 44-134
mm off, because a finger that is far from its start state does not reach its data within a
few rounds, and silhouette and edges are satisfied well enough by the fingers beside it.
Every long finger, index first, is therefore tried in each of a few states
(:data:`FINGER_STATES`; its abduction set to 0), the rest of the hand as it is; each start
gets one short round (:data:`.schedule.QUICK`), and a start whose fit scores higher than
the best so far becomes the base of the next fingers' starts (coordinate search). 13 short
fits, about 0.25 s at 4 x 320x240 on 2 cores.

Measured (mean 3D joint error). Right after the one-shot search, on sets 0 and 30 of
random-motion seeds 7020, 7021, 7022 and 7024: in the 7 sets with the palm in place it went
from 28.8 / 5.3 / 9.2 / 4.7 / 13.5 / 6.0 / 10.4 mm to 14.2 / 3.7 / 2.2 / 5.2 / 9.9 / 3.3 /
3.1 mm; with the palm turned wrong it cannot help (41.8 -> 48.0 mm, confidence 0.0 before
and after). Tracked offline from the automatic start (40 sets of random-motion seeds
8001-8008, held out): 4.89 -> 3.13 mm mean, 11.4 -> 7.8 mm over the first 10 sets, sets
more than 15 mm off 8.4 -> 1.6 %. The confidence does not rank the states of one finger
reliably (on one set a closed index finger 11 mm off scored 0.915, a curled one 4.6 mm off
0.887), so a finger can also end a little worse (4.7 -> 5.2 mm above).

The thumb is left out. With three thumb states (out, curled, across the palm) the numbers
above were 3.02 mm, 7.4 and 2.5 %, but on the robustness suite's held-out seed 300 the
search moved a thumb that was 29 mm off to 147 mm off with a higher confidence, and the
300-set sequence took 70 sets to recover (1.70 -> 4.47 mm mean): the evidence cannot judge
the thumb, which lies across the palm's silhouette in most views.

Tried and not kept: a tracked frame below ``failure.recover_below`` trying the next one or
three finger states in a cycle (one short fit each, kept when more confident). Offline it
changed nothing (6 held-out random seeds from the automatic start: 2.23 / 2.23 / 2.24 mm
mean with 0 / 1 / 3 states), in the simulated live loop (``bench/simulate_live.py --start
search``, seeds 9101-9112, twice each) one state per doubtful set tracked 82 % of the sets
on average against 83 % without. Nor the live search (:mod:`.acquisition`) trying, on every
other set, a finger state of the fit it follows before its next new start: 62 % against
63 % (seeds 3, 11, 23, 9104, 9106, 9113-9115, twice each).
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.core.observations import FrameObservations
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.layout import FINGERS, Layout
from hand_tracker_ros.model.poses import CURLED_DEG
from hand_tracker_ros.tracking.hypotheses import FLEXIONS
from hand_tracker_ros.tracking.schedule import QUICK
from hand_tracker_ros.tracking.tracker import Fit, HandTracker

# MCP, PIP and DIP flexion (deg) of a long finger in each tried state, ours: straight, half
# closed (the recovery's curled hand, :data:`hand_tracker_ros.model.poses.CURLED_DEG`) and
# closed (the synthetic fist's).
FINGER_STATES: dict[str, tuple[float, ...]] = {
    'extended': (0.0, 0.0, 0.0),
    'curled': tuple(CURLED_DEG[f'index_{joint}'] for joint in FLEXIONS),
    'closed': (75.0, 90.0, 45.0)}


def finger_states(theta: FloatArray, finger: str, model: HandModel) -> dict[str, FloatArray]:
    """``theta`` (P,) with ``finger`` (one of ``FINGERS``) in each of its states, clipped to
    the joint limits; name -> (P,)."""
    out = {}
    for name, degrees in FINGER_STATES.items():
        start = np.array(theta, np.float64)
        for joint, value in zip(FLEXIONS, degrees):
            start[Layout.index(f'{finger}_{joint}')] = np.deg2rad(value)
        start[Layout.index(f'{finger}_mcp_abd')] = 0.0
        out[f'{finger}_{name}'] = np.clip(start, model.lower, model.upper)
    return out


def search_fingers(tracker: HandTracker, observations: FrameObservations, theta: FloatArray,
                   score: Callable[[Fit], float]) -> tuple[float, FloatArray]:
    """The coordinate search of the module docstring from ``theta`` (P,) on one frame set:
    the best short fit's score and pose (the short fit of ``theta`` itself included). Leaves
    ``tracker`` reset to the last start tried."""
    fit = short_fit(tracker, observations, theta)
    best_score, best = score(fit), fit.theta
    for finger in FINGERS:
        for start in finger_states(best, finger, tracker.model).values():
            fit = short_fit(tracker, observations, start)
            value = score(fit)
            if value > best_score:
                best_score, best = value, fit.theta
    return best_score, best


def short_fit(tracker: HandTracker, observations: FrameObservations, theta: FloatArray) -> Fit:
    """One short round (:data:`.schedule.QUICK`) from ``theta``, the tracker reset to it."""
    tracker.reset(theta)
    return tracker.fit(observations, plan=QUICK, separate=False)
