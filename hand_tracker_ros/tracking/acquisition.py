"""Live acquisition: the global search of :mod:`.initialize`, spread over the incoming sets.

The one-shot search fits dozens of hypotheses to one set, seconds on 2 cores. A live tracker
cannot stop for it: the hand moves on meanwhile, and the pose found is stale by the time the
next set is taken (played at real time, the tracker found the hand in 7 of 150 sets of the
realtime demo). Here each set gets a slice of the search, ``step_budget_ms`` of wall time,
and the best fit so far follows the hand from set to set:

1. On the first set, the hand is located (the visual hull, :class:`.initialize.VisualHull`)
   and the relaxed-hand hypotheses are ranked by silhouette IoU, as in the one-shot search
   (:func:`.initialize.ranked_hypotheses`), but not slid along the hull's axis: in the
   simulated live loop (``bench/simulate_live.py --seeds 3570 ... 3581 --frames 120
   --repeats 2``) a version that slid them tracked a mean of 72 % of the sets, with 4 of 24
   runs under 40 %, against 78 % and 2 runs without the slide.
2. On the first set, the best hypotheses get short fits (:data:`.schedule.QUICK`) until the
   budget left is what a full fit takes or one of them is ``confident`` (the session's
   ``lost_below``), and the most confident of them gets the full schedule. (Stopping there
   leaves the hand less time to move before it is followed: in the simulated live loop,
   ``bench/simulate_live.py --seeds 3570 ... 3581 --frames 120 --repeats 2``, three runs
   tracked a mean of 82, 84 and 85 % of the sets against 82, 78 and 78 % without the stop,
   and with ``--slowdown 1.5`` 46 and 52 % against 49 and 45 %, within the loop's
   run-to-run spread; a first set of 300 instead of 60 ms, exploring more, tracked 59 %
   against 85 %.) On every later set the best fit so far, moved by the displacement of the
   hull centre since its set, gets the full schedule first (while it is near the hand, that
   is tracking it), and untried hypotheses, centred on this set's hull centre, get short
   fits with the rest of the budget: at least one per set, so that a carried fit stuck in a
   wrong basin does not stop the search. Once every hypothesis was tried they are ranked
   again.
3. The full fit is the set's estimate. When its confidence reaches the session's
   ``lost_below`` the hand is acquired and tracking goes on from it; otherwise the set is
   LOST, and the more confident of the full fit and the best short fit is carried to the
   next set.

The budget is short on purpose: what a set must do (the carried fit's full schedule, one
short fit) already takes more (85-140 ms offline at 4 x 320x240, 150-300 ms in the live
graph), and the hand moves on meanwhile. The simulated live loop
(``bench/simulate_live.py --start search``, seeds 901-912, tracked share per seed) gave a
mean of 62 % at 120 ms (three seeds under 40 %), 67 % at 80, 76 % at 60 (none under 50 %)
and 76 % at 40 (one at 0 %); the realtime demo (``hand-tracker demo``, seeds
0, 3, 7, 11, 19, 23) then tracked a median of 46 % of the sets at 60 ms against 29 % at
120, better on five of the six. The session's live recovery shares this budget.

A first version made a short fit of the carried fit too and gave the full schedule to the
most confident short fit: one short fit more per set, and no better in the simulated live
loop (``bench/simulate_live.py``, seeds 601-605, whose sets estimated vary by 20-40 points
from run to run with either).

The session runs this when a set must be fitted by a deadline (the live tracker) and it
searches: at the start without an initial pose, and after losses unless it may not search
(:mod:`.session`); offline it runs the one-shot search, which spends what it needs on one
set.
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.config import param
from hand_tracker_ros.core.observations import FrameObservations
from hand_tracker_ros.model.layout import Layout
from hand_tracker_ros.tracking.fingers import short_fit
from hand_tracker_ros.tracking.initialize import (
    HandRegion,
    InitConfig,
    VisualHull,
    ranked_hypotheses,
)
from hand_tracker_ros.tracking.schedule import rounds
from hand_tracker_ros.tracking.tracker import Fit, HandTracker


@dataclass(frozen=True)
class AcquisitionConfig:
    """The live search's share of each set."""

    step_budget_ms: float = param(60.0, 'wall time of the search per set (short fits and one '
                                  'full fit; module docstring)', unit='ms', low=1.0,
                                  high=10000.0)


@dataclass(frozen=True, eq=False)
class _Candidate:
    theta: FloatArray      # (P,) pose (m, rad)
    centre_m: FloatArray   # (3,) hull centre of the set it was fitted to (m)


class Acquisition:
    """One live search for the hand (module docstring).

    ``score(fit, observations)`` ranks fits (higher is better: the session's confidence).
    ``start`` (P,), optional, is the first carried candidate (e.g. the last estimate before
    the hand was lost). Without one, a short fit scoring ``confident`` ends the first
    set's exploring.
    """

    def __init__(self, tracker: HandTracker, init: InitConfig, config: AcquisitionConfig,
                 score: Callable[[Fit, FrameObservations], float],
                 start: FloatArray | None = None, confident: float = math.inf) -> None:
        self._tracker, self._init, self._config, self._score = tracker, init, config, score
        self._confident = confident
        self._pending: list[FloatArray] = []   # untried hypotheses, best IoU first
        self._carried: _Candidate | None = None
        self._start = None if start is None else np.asarray(start, np.float64).copy()
        self._full_s = 0.0       # duration of the last full fit, s (0: none yet)
        self._rounds = len(rounds(tracker.config.schedule))
        self._hull = VisualHull(tracker.cameras)     # the hand is located on every set
        self._ranking = replace(init, slide_best=0)    # not slid (module docstring)

    def step(self, observations: FrameObservations) -> Fit:
        """Search on one set for about ``step_budget_ms``; the set's full fit.

        Raises ``HandTrackerError`` when the hand cannot be located (fewer than two cameras
        see foreground).
        """
        deadline_s = time.monotonic() + self._config.step_budget_ms / 1e3
        region = self._hull.locate(observations, self._init.min_mask_px)
        centre = region.centre_m
        if self._carried is None and self._start is not None:
            self._carried = _Candidate(self._start, centre)
        if not self._pending:
            self._pending = ranked_hypotheses(self._tracker, observations, region,
                                              self._ranking)
        if self._carried is None:
            # Nothing to follow yet: short fits, then the most confident gets the full fit.
            best = self._explore(observations, region, deadline_s, reserve_full=True)
            full, full_score = self._full_fit(best[1].theta, observations)
            kept = (full_score, full) if full_score >= best[0] else best
        else:
            # Follow the best fit so far, then spend the rest of the budget on new starts.
            full, full_score = self._full_fit(self._moved(self._carried, centre), observations)
            best = self._explore(observations, region, deadline_s, reserve_full=False)
            kept = best if best[0] > full_score else (full_score, full)
        self._carried = _Candidate(kept[1].theta, centre)
        return full

    def _explore(self, observations: FrameObservations, region: HandRegion, until_s: float,
                 reserve_full: bool) -> tuple[float, Fit]:
        """Short fits of untried hypotheses, centred at the region's centre, while the next
        one ends before ``until_s`` (``time.monotonic``; at least one), leaving a full fit's
        time when ``reserve_full`` (and then only until one is ``confident``); the most
        confident with its score. Before a full fit was timed it is reckoned at one short
        fit per scheduled round; reserving nothing for it, the first set of a search
        explored for the whole budget and ran its full fit on top."""
        best: tuple[float, Fit] | None = None
        while self._pending:
            t0 = time.monotonic()
            theta = self._centred(self._pending.pop(0), region.centre_m)
            fit = short_fit(self._tracker, observations, theta)
            score = self._score(fit, observations)
            if best is None or score > best[0]:
                best = (score, fit)
            now = time.monotonic()
            short_s = now - t0
            reserve_s = (self._full_s or self._rounds * short_s) if reserve_full else 0.0
            if now + short_s + reserve_s > until_s or (reserve_full
                                                        and best[0] >= self._confident):
                break
        if not self._pending:
            self._pending = ranked_hypotheses(self._tracker, observations, region,
                                              self._ranking)
        assert best is not None
        return best

    def _full_fit(self, theta: FloatArray, observations: FrameObservations
                  ) -> tuple[Fit, float]:
        t0 = time.monotonic()
        self._tracker.reset(theta)
        fit = self._tracker.fit(observations)
        self._full_s = time.monotonic() - t0
        return fit, self._score(fit, observations)

    def _centred(self, theta: FloatArray, centre: FloatArray) -> FloatArray:
        """``theta`` translated so that its mesh centroid is at ``centre``."""
        posed = self._tracker.model.pose(theta, jacobian=False)
        out = theta.copy()
        out[Layout.translation] += centre - posed.vertices_m.mean(axis=0)
        return out

    @staticmethod
    def _moved(candidate: _Candidate, centre: FloatArray) -> FloatArray:
        """The carried pose, moved as the hull centre moved since its set."""
        out = candidate.theta.copy()
        out[Layout.translation] += centre - candidate.centre_m
        return out
