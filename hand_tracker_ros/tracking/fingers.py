"""Finger-wise search: one finger at a time is put in other states and the hand refitted.

The global search (:mod:`.initialize`) starts from relaxed hands. When it ends with the palm
in place, what is left wrong is one or two fingers: on sets 0 and 30 of random-motion seeds
7020-7024 the palm keypoints (wrist and finger bases) were within 1-4 mm of the truth in 9 of
the 10 searched sets while the mean error was 5.7-28.8 mm, because a finger that is far from
its start state does not reach its data within a few rounds, and silhouette and edges are
satisfied well enough by the fingers beside it.
Every long finger, index first, is therefore tried in each of a few states
(:data:`FINGER_STATES`; its abduction set to 0), the rest of the hand as it is; each start
gets one short round (:data:`.schedule.QUICK`), and a start whose fit scores higher than
the best so far becomes the base of the next fingers' starts (coordinate search). 12 short
fits, about 0.25 s at 4 x 320x240 on 2 cores.

Measured (mean 3D joint error). Right after the one-shot search on those 10 sets, without /
with the finger search (run from any result): 28.8 / 11.6, 8.7 / 4.3, 9.2 / 4.1, 5.7 / 7.9,
25.8 / 5.1, 13.5 / 10.7, 16.6 / 5.3, 6.0 / 4.0 and 7.9 / 5.2 mm on the 9 with the palm in
place; on the one with the palm turned wrong (30.6 mm off) it cannot help (27.2 mm both).
Tracked offline from the automatic start (40 sets of random-motion seeds 8001-8008, held
out), as the session runs it (below): 4.89 -> 3.35 mm mean, 11.4 -> 8.8 mm over the first 10
sets, sets more than 15 mm off 8.4 -> 2.5 %. The confidence does not rank the states of one
finger reliably (on one set a closed index finger 11 mm off scored 0.915, a curled one
4.6 mm off 0.887), so a finger can also end worse (5.7 -> 7.9 mm above).

The session runs it only from a search result it would report TRACKING (confidence at least
``failure.lost_below``): from a less confident one the palm is likely wrong as well, and
the finger states can make a wrong palm look confident. With 2 cameras (robustness suite,
seeds 300-303) the finger search from any result gave 10.06 mm mean and flagged LOST 18 of
24 frames more than 30 mm off (a restart's 49 mm fit scored 0.87 after it); from confident
results only 8.93 mm and 23 of 26 (without the finger search 10.03 mm, 19 of 20). On seeds
8001-8008 above the threshold costs 0.23 mm (3.35 against 3.12 mm from any result, 7.8
instead of 8.8 mm over the first 10 sets): seed 8003 started below it and lost its gain.

The thumb is left out. A first version had three thumb states (out, curled, across the
palm) and also refitted the search's best with a short fit: 3.02 mm, 7.4 mm and 2.5 % on
the tracked seeds above, but on the robustness suite's held-out seed 300 it moved a thumb
that was 29 mm off to 147 mm off at a higher confidence, and that 300-set sequence took 70
sets to recover (1.70 -> 4.47 mm mean): the evidence cannot judge the thumb, which lies
across the palm's silhouette in most views.

Tried and not kept: a tracked frame below ``failure.recover_below`` trying the next one or
three finger states in a cycle (one short fit each, kept when more confident). Offline it
changed nothing (6 held-out random seeds from the automatic start: 2.23 / 2.23 / 2.24 mm
mean with 0 / 1 / 3 states), in the simulated live loop (``bench/simulate_live.py --start
search``, seeds 9101-9112, twice each) one state per doubtful set tracked 82 % of the sets
on average against 83 % without. Nor the live search (:mod:`.acquisition`) trying, on every
other set, a finger state of the fit it follows before its next new start: 62 % against
63 % (seeds 3, 11, 23, 9104, 9106, 9113-9115, twice each).

**Pinned fingers** (the session's step 4b). A tracked finger can leave its data and settle,
at a confidence of 0.95-0.99, in a pose the data of its neighbours holds: on a 0.9x hand
tapping (``hand-tracker synth --motion tapping --seed 3433 --frames 90`` with ``scale: 0.9``,
tracked with ``--shape`` that shape, ``--fixed-scale --init ground-truth``) the resting ring
finger went within three frames to MCP -30 deg (its hyperextension limit), PIP 94 and DIP 61
while the index finger tapped, 46-57 mm off at its tip; refitted from the true finger it
stayed there, at a higher confidence (0.994 against 0.977) and a lower cost (10300 against
14500; the silhouette's halved), so the data prefers the right pose, but no start reached
it. Such fits press the finger against a limit no ground truth of the synthetic motions
reaches: over 3600 finger-frames of ten such bags (seeds 3431-3440, from the true first
pose), 130 of the 151 more than 25 mm off at the tip had MCP at its hyperextension limit or
PIP or DIP at full flexion (within 2 deg), against 17 of the 3119 within 10 mm. No ground
truth does, by construction (random motion keeps to 80 % of every range, the scripted poses
lie inside); straight fingers rest at PIP 0, which is why the extension limits of PIP and
DIP do not count. :func:`pinned_fingers` finds such fingers (:data:`PINNING_LIMITS`), and
:func:`unpinning_starts` gives the session the fit with each of them in every
:data:`FINGER_STATES` and as in the last trusted estimate with no finger pinned (the last
trusted one is often the stuck fit itself); they are judged like the recovery's hypotheses
(the most confident wins, and only if more confident than the fit). A real fist pressed to
full flexion triggers it too; the fit is then kept when no other state is more confident.

The thumb is pinned at any of its eight limits (its four DOF, both sides). Its wrong fits
press there as well, where the ground truth of random motion (80 % of every range) never
goes: tracked from the automatic start (``hand-tracker track`` conditions; random seeds
3569 and 3587-3590, clutter 40 of the robustness suite on seeds 3583 and 3584), 136 of the
208 frames with the thumb tip more than 25 mm off had a thumb DOF within 2 deg of a limit
(MCP flexion in 105, IP flexion in 57, CMC flexion in 47, CMC abduction in 8), against 19
of the 980 within 10 mm. The refit's starts differ from the fit only in the thumb (its
three states and the trusted thumb); the evidence still cannot always judge the thumb,
the reason the finger search leaves it out (above). With it, the mean 3D joint error on
those sequences went from 11.30 to 6.12 mm (seed 3569, whose thumb was pinned from the
first set on), 5.82 to 5.27 and 7.67 to 7.76 (clutter 40), and stayed within 0.01 mm on
the four others. Held out: ten bags (random 3591-3594, 3599 and 3600, 150 frames; grasp
3595, pinch 3596, fist 3597, tapping 3598, 90 frames) stayed within 0.06 mm but for random
3599 (2.44 to 1.61 mm); with 2 cameras (robustness suite, seeds 3584, 3585, 3601-3606,
3623 and 3624) the mean went from 7.12 to 6.57 mm, lower on eight seeds and higher on two
(3602 5.31 to 7.68, 3605 5.15 to 6.66; not examined frame by frame). In the simulated
live loop (``bench/simulate_live.py --frames 120``, the old and new code in alternation,
two runs each on seeds 3607-3614 and on 3615-3622) the new code tracked 78 and 75 % of
the sets against 83 and 86 %, and 87 and 89 % against 92 and 91 %; each time one seed collapsed
(3611, 3618), which run alone in three alternating pairs tracked 87, 87, 87 % against 87,
60, 87 % (3611) and 58, 47, 68 % against 66, 54, 53 % (3618): within the loop's spread, but
a live cost of a few points is not excluded. A real thumb can reach its limits (IP
hyperextension, full CMC abduction), which the synthetic motions do not: such a hand is
refitted on every frame offline and every ``pinned.live_every``-th set live, and its fit is
kept when no other thumb state is more confident.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.core.observations import FrameObservations
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.layout import FINGERS, Layout
from hand_tracker_ros.model.poses import CURLED_DEG, FIST_DEG
from hand_tracker_ros.tracking.schedule import QUICK
from hand_tracker_ros.tracking.tracker import Fit, HandTracker

# The tried states of a finger (deg by joint name; a finger's DOF not named are 0, its
# abduction among them): every DOF 0, as in the half-closed hand and as in the fist with the
# thumb outside of :mod:`hand_tracker_ros.model.poses`. For the thumb these are all four DOF
# 0, (10, 30, 30, 30) and (10, 30, 20, 10) (CMC flexion and abduction, MCP and IP flexion).
FINGER_STATES: dict[str, Mapping[str, float]] = {
    'extended': {}, 'curled': CURLED_DEG, 'closed': FIST_DEG}


def finger_states(theta: FloatArray, finger: str, model: HandModel) -> dict[str, FloatArray]:
    """``theta`` (P,) with ``finger`` ('thumb' or one of ``FINGERS``) in each of its states,
    clipped to the joint limits; name -> (P,)."""
    own = Layout.per_finger[finger]
    out = {}
    for name, degrees in FINGER_STATES.items():
        start = np.array(theta, np.float64)
        start[own] = np.deg2rad([degrees.get(joint, 0.0) for joint in Layout.names[own]])
        out[f'{finger}_{name}'] = np.clip(start, model.lower, model.upper)
    return out


# The limits a wrongly fitted finger is pressed against (module docstring, "Pinned
# fingers"): finger -> (joint, side) pairs. Every limit of the thumb's four DOF.
PINNING_LIMITS: dict[str, tuple[tuple[str, str], ...]] = {
    **{finger: ((f'{finger}_mcp_flex', 'lower'), (f'{finger}_pip_flex', 'upper'),
                (f'{finger}_dip_flex', 'upper')) for finger in FINGERS},
    'thumb': tuple((joint, side) for joint in Layout.names[Layout.thumb]
                   for side in ('lower', 'upper'))}


def pinned_fingers(theta: FloatArray, model: HandModel, margin_rad: float) -> list[str]:
    """The fingers of ``theta`` (P,) with a joint within ``margin_rad`` of one of their
    :data:`PINNING_LIMITS` (of ``model``'s limits), index first and the thumb last."""
    pinned = []
    for finger, limits in PINNING_LIMITS.items():
        for joint, side in limits:
            k = Layout.index(joint)
            gap = theta[k] - model.lower[k] if side == 'lower' else model.upper[k] - theta[k]
            if gap <= margin_rad:
                pinned.append(finger)
                break
    return pinned


def unpinning_starts(theta: FloatArray, fingers: list[str], model: HandModel,
                     trusted: FloatArray | None) -> dict[str, FloatArray]:
    """Starts for a fit whose ``fingers`` are pinned: ``theta`` (P,) with one of them in each
    of its :data:`FINGER_STATES` and, given ``trusted`` (P,), as it was there; name -> (P,)."""
    starts = {}
    for finger in fingers:
        starts.update(finger_states(theta, finger, model))
        if trusted is not None:
            own = Layout.per_finger[finger]
            start = np.array(theta, np.float64)
            start[own] = trusted[own]
            starts[f'{finger}_trusted'] = start
    return starts


def search_fingers(tracker: HandTracker, observations: FrameObservations,
                   start: tuple[float, FloatArray], score: Callable[[Fit], float]
                   ) -> tuple[float, FloatArray]:
    """The coordinate search of the module docstring on one frame set from ``start``, a
    fitted pose (P,) with its score: the best score and pose, ``start`` when no finger state
    scores higher. Leaves ``tracker`` reset to the last start tried."""
    best_score, best = start
    for finger in FINGERS:
        for candidate in finger_states(best, finger, tracker.model).values():
            fit = short_fit(tracker, observations, candidate)
            value = score(fit)
            if value > best_score:
                best_score, best = value, fit.theta
    return best_score, best


def short_fit(tracker: HandTracker, observations: FrameObservations, theta: FloatArray) -> Fit:
    """One short round (:data:`.schedule.QUICK`) from ``theta`` (P,), the tracker reset to
    it."""
    tracker.reset(theta)
    return tracker.fit(observations, plan=QUICK, separate=False)
