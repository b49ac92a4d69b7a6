"""The tracking session: one policy for initialising, tracking, failure and recovery.

The offline pipeline and the tracker node both drive a :class:`TrackingSession`, so a bag
tracked offline and the same bag played through the graph follow the same rules:

1. **Start.** Without a history the session finds the hand: from ``initial_pose`` when one is
   given, otherwise by the global search over the observations (:mod:`.initialize`). A set
   with a deadline (the live tracker) gets a slice of the search instead, which goes on over
   the following sets, LOST until it finds the hand (:mod:`.acquisition`). The initial pose
   holds for the start only: once the hand has moved on, a restart from it lands where the
   hand was (played from the ground truth's first pose, a lost tracker re-initialised there
   was LOST for the rest of the bag), so restarts search (step 5) unless the session may not
   search.
2. **Track.** The frame is fitted from the constant-velocity prediction of the last two
   accepted estimates, scaled by the time since them (sets a live tracker skipped count;
   :mod:`.hypotheses`; ``predict``), or from the last estimate.
3. **Judge.** The fit's image evidence gives a confidence in [0, 1] (:mod:`.evidence`).
4. **Recover locally** when the confidence is below ``failure.recover_below``: the frame is
   fitted again, one short round each, from the previous estimate, from the hand turned
   about its own axes (palm flips, quarter turns; of the new fit and of the last estimate the
   session trusted) and from the new fit's palm with other fingers (relaxed, half closed, two
   neighbours' flexions swapped: :func:`.hypotheses.finger_hypotheses`,
   :func:`.hypotheses.swapped_fingers`); the most confident of them gets the full schedule
   and replaces the fit if it is more confident. This costs time only on doubtful frames.
4b. **Unpin fingers** (``pinned``) when a long finger of the kept fit presses against MCP
   hyperextension or full PIP or DIP flexion, or the thumb against any of its limits, where
   wrong fits end and no motion's ground truth goes (:mod:`.fingers`, "Pinned fingers"):
   the frame is fitted again with each such finger in other states and as in the last
   trusted estimate with none pinned, chosen as in step 4, whatever the confidence (such
   fits score 0.95-0.99). Live, only every ``pinned.live_every``-th set a finger stays
   pinned, within what is left of the set's step budget (step 4 shares it).
5. **Search globally** when ``failure.reinit_after`` consecutive frames stayed below
   ``failure.lost_below``: the search runs on the current frame (with a deadline: the live
   search starts from the last fit, on the next set); a session that may not search resets
   to ``initial_pose`` instead (a user who shows that pose to restart).
6. **Report.** The frame is TRACKING when the kept fit's confidence is at least
   ``failure.lost_below``, LOST otherwise. The kept fit is the next frame's start either way
   (a LOST frame can still be the best guess there is), and the last TRACKING estimate stays a
   recovery start.
7. **Follow the hand's size** (``scale``, :mod:`.scale`): every few frames the kept fit (a
   live search's too) measures the hand's global scale; when the measurements disagree with
   the model, the model is rebuilt at the measured scale (the history is kept,
   :meth:`HandTracker.reshape`), a few percent at a time, from the next frame on. Results
   carry the model they were posed with.
"""
from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass
from typing import TypeVar

import numpy as np

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.config import nested, param
from hand_tracker_ros.core.observations import FrameObservations
from hand_tracker_ros.core.result import TrackResult
from hand_tracker_ros.energies.registry import SIZE_TERMS
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.status import TrackStatus
from hand_tracker_ros.tracking.acquisition import Acquisition, AcquisitionConfig
from hand_tracker_ros.tracking.evidence import EvidenceConfig, confidence, measure
from hand_tracker_ros.tracking.fingers import pinned_fingers, unpinning_starts
from hand_tracker_ros.tracking.hypotheses import (
    constant_velocity,
    finger_hypotheses,
    swapped_fingers,
    turned_hypotheses,
)
from hand_tracker_ros.tracking.initialize import InitConfig, initialize
from hand_tracker_ros.tracking.scale import FrameScale, ScaleConfig, ScaleRefiner
from hand_tracker_ros.tracking.schedule import QUICK
from hand_tracker_ros.tracking.tracker import Fit, HandTracker

LOG = logging.getLogger(__name__)
_T = TypeVar('_T')


@dataclass(frozen=True)
class FailureConfig:
    """When a frame is doubted, lost, and when the hand is searched for again."""

    lost_below: float = param(0.5, 'a fit less confident than this is LOST', low=0.0,
                              high=1.0)
    recover_below: float = param(0.9, 'a fit less confident than this tries the recovery '
                                 'hypotheses', low=0.0, high=1.0)
    reinit_after: int = param(3, 'consecutive LOST frames before the global search',
                              low=1, high=1000)


@dataclass(frozen=True)
class PinnedConfig:
    """Step 4b: fits with a finger pressed against a limit are refitted with that finger
    elsewhere."""

    enabled: bool = param(True, 'refit a fit whose long finger presses against MCP '
                          'hyperextension or full PIP or DIP flexion, or whose thumb '
                          'presses against a limit')
    margin_deg: float = param(2.0, 'a joint this close to such a limit presses against it',
                              unit='deg', low=0.0, high=30.0)
    live_every: int = param(3, 'live: refit only every this many sets a finger stays '
                            'pinned (each refit holds its set up)', low=1, high=1000)


@dataclass(frozen=True)
class SessionConfig:
    """The tracking session's policy."""

    predict: bool = param(True, 'start each frame from the constant-velocity prediction')
    recovery: bool = param(True, 'refit doubtful frames from the recovery hypotheses')
    failure: FailureConfig = nested(FailureConfig)
    pinned: PinnedConfig = nested(PinnedConfig)
    evidence: EvidenceConfig = nested(EvidenceConfig)
    init: InitConfig = nested(InitConfig)
    acquisition: AcquisitionConfig = nested(AcquisitionConfig)
    scale: ScaleConfig = nested(ScaleConfig)


@dataclass(frozen=True, eq=False)
class _Judged:
    """A fit with its evidence and confidence."""

    name: str
    fit: Fit
    evidence: dict[str, float]
    confidence: float


class TrackingSession:
    """Tracks one hand through a sequence of frame sets with :class:`HandTracker`.

    ``initial_pose`` (P,) replaces the global search at the start; after losses the session
    searches. With ``search=False`` it never searches: it resets to ``initial_pose`` after
    losses, or without one the caller resets it (the evaluation's ground-truth protocol) and
    :attr:`lost_frames` says when.
    """

    def __init__(self, tracker: HandTracker, config: SessionConfig = SessionConfig(), *,
                 initial_pose: FloatArray | None = None, search: bool = True) -> None:
        self.tracker = tracker
        self.config = config
        self._initial = None if initial_pose is None else np.asarray(initial_pose, np.float64)
        self._search = search
        self._lost = 0
        self._pinned_sets = 0     # consecutive sets whose fit had a pinned finger (step 4b)
        self._trusted: FloatArray | None = None
        # The last trusted estimate with no finger pinned (step 4b's start; the last trusted
        # one is often the stuck fit itself).
        self._unpinned: FloatArray | None = None
        self._stamps: list[int] = []    # stamps (ns) of the tracker's history, when known
        self._acquisition: Acquisition | None = None     # a live search in progress
        self.restarts = 0     # starts (initial pose or search) after losses, in all
        self.status: TrackStatus | None = None     # of the last frame; None before one
        self._scale = (ScaleRefiner(config.scale, tracker.model.shape.scale)
                       if config.scale.enabled else None)
        # A live scale move's model being built: (its scale, the build).
        self._building: tuple[float, Future[HandModel]] | None = None

    @property
    def initialized(self) -> bool:
        """True once the session has a pose to start from."""
        return self.tracker.initialized

    @property
    def lost_frames(self) -> int:
        """Consecutive LOST frames."""
        return self._lost

    def reset(self, theta: FloatArray | None = None) -> None:
        """Forget everything; start from ``theta``, or on the next frame as at the start
        (step 1: from ``initial_pose``, or by the search)."""
        self.tracker.reset(theta)
        self._lost = 0
        self._pinned_sets = 0
        self._trusted = None if theta is None else np.asarray(theta, np.float64).copy()
        self._unpinned = (self._trusted if self._trusted is not None
                          and not self._pinned(self._trusted) else None)
        self._stamps = []
        self._acquisition = None
        self.status = None

    @property
    def restarts_from(self) -> str:
        """Where a restart after losses starts: ``'observations'`` (the search) or
        ``'initial_pose'`` (module docstring, step 5)."""
        return 'observations' if self._searches(restart=True) else 'initial_pose'

    @property
    def acquiring(self) -> bool:
        """True while a live search for the hand is in progress."""
        return self._acquisition is not None

    def step(self, observations: FrameObservations, *,
             deadline_s: float | None = None) -> TrackResult:
        """Track one frame set (module docstring). Raises ``HandTrackerError`` when no hand
        can be found to start from (e.g. fewer than two cameras see foreground).

        ``deadline_s`` (``time.monotonic``) marks a live frame. It caps the frame's main fit
        (the rounds that :meth:`HandTracker.fit` may start); the frame is refitted from the
        recovery hypotheses only below ``failure.lost_below`` (not already below
        ``failure.recover_below``) and for pinned fingers only every ``pinned.live_every``-th
        set (step 4b), both within one ``acquisition.step_budget_ms``; a search is spread
        over the sets (:mod:`.acquisition`). Without it, recovery, step 4b and the one-shot
        search spend what they need.
        """
        start = time.perf_counter()
        timings: dict[str, float] = {}
        self._take_built_model()
        if (not self.tracker.initialized and self._searches_live(deadline_s, restart=False)
                and self._acquisition is None):
            self._acquisition = self._new_acquisition(None)
        if self._acquisition is not None:
            return self._acquire(observations, timings, start)
        if not self.tracker.initialized:
            self._start(observations, timings, restart=False)
        start_theta = self._prediction(observations.stamp_ns)
        judged = self._judge('previous', self._fit(observations, start_theta, timings,
                                                   deadline_s), observations)
        iterations = judged.fit.iterations
        failure = self.config.failure
        # A live frame is refitted from the recovery hypotheses only when it would be LOST,
        # and the refits of a live frame (steps 4 and 4b) share the acquisition's step
        # budget: a doubtful frame's full recovery (a dozen fits when this was measured,
        # about 0.3 s on 2 cores; 15 short fits and a full one now) skipped the next ten
        # sets, and the larger step to them made those doubtful too (simulated at 30 Hz,
        # tracking from the true pose went that way from 79 % of the sets estimated to 26 %
        # on one seed).
        live = deadline_s is not None
        budget_end = (time.monotonic() + self.config.acquisition.step_budget_ms / 1e3
                      if live else None)
        recover_below = failure.lost_below if live else failure.recover_below
        if self.config.recovery and judged.confidence < recover_below:
            t0 = time.perf_counter()
            judged, spent = self._recover(judged, observations, timings, budget_end)
            iterations += spent
            timings['recovery'] = time.perf_counter() - t0
        pinned = self._pinned(judged.fit.theta)
        self._pinned_sets = self._pinned_sets + 1 if pinned else 0
        live_turn = (self._pinned_sets % self.config.pinned.live_every == 0
                     and budget_end is not None and time.monotonic() < budget_end)
        if pinned and (not live or live_turn):
            t0 = time.perf_counter()
            starts = unpinning_starts(judged.fit.theta, pinned, self.tracker.model,
                                      self._unpinned)
            judged, spent = self._best_of(judged, starts, observations, timings, budget_end)
            iterations += spent
            timings['pinned'] = time.perf_counter() - t0
        searched_now = (judged.confidence < failure.lost_below and self._can_start
                        and self._lost + 1 >= failure.reinit_after)
        if searched_now and self._searches_live(deadline_s, restart=True):
            # Live: the search starts on the next set, from this fit, a slice per set.
            self._acquisition = self._new_acquisition(judged.fit.theta)
            self.restarts += 1
            searched_now = False
        if searched_now:
            t0 = time.perf_counter()
            self._start(observations, timings, restart=True)
            self.restarts += 1
            # Without the search, the restart is a fit from ``initial_pose``; named so.
            searched = self._judge('search' if self._searches(restart=True) else 'initial_pose',
                                   self._fit(observations, None, timings), observations)
            iterations += searched.fit.iterations
            timings['search'] = time.perf_counter() - t0
            if searched.confidence > judged.confidence:
                judged = searched
        result = self._report(judged, observations.stamp_ns, iterations, timings, start,
                              continues=judged.name == 'previous' and not searched_now)
        self._follow_scale(judged, observations, result.timings_s, live)
        return result

    def _report(self, judged: _Judged, stamp_ns: int, iterations: int,
                timings: dict[str, float], start: float, continues: bool) -> TrackResult:
        """Settle the frame's kept fit (:meth:`_settle`) and say what it was."""
        status = self._settle(judged, stamp_ns, continues)
        timings['total'] = time.perf_counter() - start
        self.status = status
        fit = judged.fit
        return TrackResult(stamp_ns, status, fit.theta, fit.posed, iterations,
                           fit.energy_costs, judged.confidence, judged.evidence, timings,
                           fit.labels, '' if judged.name == 'previous' else judged.name,
                           lm_statuses=fit.lm_statuses)

    def _follow_scale(self, judged: _Judged, observations: FrameObservations,
                      timings: dict[str, float], live: bool) -> None:
        """Step 7: measure the hand's scale on a due frame (live too, past the set's
        deadline: about 5 ms every third set, ``bench/bench_scale.py``; a hand of the wrong
        size is what keeps a live search LOST) and rebuild the model at the scale the refiner
        moves to. The build (about 65 ms) runs here offline, so that a bag is tracked the
        same every time; live, on a thread of its own, and the tracker takes the model at the
        first set after it is built (:meth:`_take_built_model`); meanwhile the estimates,
        which are absolute, are compared with the scale being built. The time spent is
        ``timings['scale']``, part of ``total``."""
        refiner = self._scale
        if (refiner is None or not np.all(np.isfinite(judged.fit.theta))
                or not refiner.due(judged.confidence)):
            return
        t0 = time.perf_counter()
        model = self.tracker.model
        target = model.shape.scale if self._building is None else self._building[0]
        terms = [t for t in self.tracker.terms if t.name in SIZE_TERMS]
        frame = FrameScale(terms, judged.fit.posed, judged.fit.views, observations)
        scale = refiner.update(target, frame.estimate())
        if scale is not None:
            LOG.info('hand scale %.3f -> %.3f', target, scale)
            shape = model.shape.replace(scale=scale)
            if live:
                self._building = (scale, _in_thread(HandModel.build, shape))
            else:
                self.tracker.reshape(HandModel.build(shape))
        timings['scale'] = time.perf_counter() - t0
        timings['total'] += timings['scale']

    def _take_built_model(self) -> None:
        """Track the model the last live scale move built, once it is ready (step 7)."""
        if self._building is not None and self._building[1].done():
            built, self._building = self._building[1], None
            self.tracker.reshape(built.result())

    def _searches(self, restart: bool) -> bool:
        """Whether a start (``restart``: after losses) searches rather than resets to
        ``initial_pose`` (module docstring, steps 1 and 5)."""
        return self._search and (restart or self._initial is None)

    def _searches_live(self, deadline_s: float | None, restart: bool) -> bool:
        """Whether a start is the search spread over the sets: a live frame (with a
        deadline) of a start that searches."""
        return deadline_s is not None and self._searches(restart)

    def _new_acquisition(self, start: FloatArray | None) -> Acquisition:
        return Acquisition(self.tracker, self.config.init, self.config.acquisition,
                           lambda fit, obs: self._judge('search', fit, obs).confidence, start,
                           confident=self.config.failure.lost_below)

    def _acquire(self, observations: FrameObservations, timings: dict[str, float],
                 start: float) -> TrackResult:
        """One set of a live search: its best fit, TRACKING once confident (the search
        ends), LOST before."""
        assert self._acquisition is not None
        self._pinned_sets = 0
        t0 = time.perf_counter()
        fit = self._acquisition.step(observations)
        timings['search'] = time.perf_counter() - t0
        judged = self._judge('search', fit, observations)
        if judged.confidence >= self.config.failure.lost_below:
            self._acquisition = None
        result = self._report(judged, observations.stamp_ns, fit.iterations, timings, start,
                              continues=False)
        self._follow_scale(judged, observations, result.timings_s, live=True)
        return result

    @property
    def _can_start(self) -> bool:
        return self._initial is not None or self._search

    def _start(self, observations: FrameObservations, timings: dict[str, float],
               restart: bool) -> None:
        """Reset the tracker to the global search's pose or to ``initial_pose``."""
        t0 = time.perf_counter()
        if self._searches(restart):
            initialize(self.tracker, observations, self.config.init,
                       score=lambda fit: self._judge('search', fit, observations).confidence,
                       fingers_from=self.config.failure.lost_below)
        elif self._initial is not None:
            self.tracker.reset(self._initial)
        else:
            msg = 'the session is not initialized and may not search: call reset(theta)'
            raise RuntimeError(msg)
        timings['initialize'] = timings.get('initialize', 0.0) + time.perf_counter() - t0

    def _prediction(self, stamp_ns: int) -> FloatArray | None:
        """The start of the frame's fit: None for the last estimate itself."""
        history = self.tracker.history
        if not self.config.predict or history.shape[0] < 2 or len(self._stamps) < 2:
            return None
        t0, t1 = self._stamps[-2:]
        if not t0 < t1 <= stamp_ns:
            return None
        return constant_velocity(history, self.tracker.model, (stamp_ns - t1) / (t1 - t0))

    def _fit(self, observations: FrameObservations, start: FloatArray | None,
             timings: dict[str, float], deadline_s: float | None = None) -> Fit:
        fit = self.tracker.fit(observations, start, deadline_s=deadline_s)
        for key, value in fit.timings_s.items():
            timings[key] = timings.get(key, 0.0) + value
        return fit

    def _pinned(self, theta: FloatArray) -> list[str]:
        """The fingers (the thumb included) of ``theta`` (P,) step 4b refits (none when it
        is off)."""
        if not self.config.pinned.enabled:
            return []
        return pinned_fingers(theta, self.tracker.model,
                              np.deg2rad(self.config.pinned.margin_deg))

    def _judge(self, name: str, fit: Fit, observations: FrameObservations) -> _Judged:
        evidence = measure(fit.views, observations, fit.posed.fingertips_m,
                           self.config.evidence)
        if not np.all(np.isfinite(fit.theta)):
            return _Judged(name, fit, evidence, 0.0)
        return _Judged(name, fit, evidence, confidence(evidence, self.config.evidence))

    def _recover(self, first: _Judged, observations: FrameObservations,
                 timings: dict[str, float], budget_end: float | None = None
                 ) -> tuple[_Judged, int]:
        """The most confident of ``first`` and the fits from the recovery hypotheses.

        Each hypothesis gets one short round (:data:`.schedule.QUICK`); only the most confident
        of them is then fitted with the full schedule, and it replaces ``first`` if it is more
        confident. With ``budget_end`` (``time.monotonic``) the short rounds stop, after the
        first, once what is left of the budget is what ``first``'s fit took (the full fit's
        share).
        """
        model = self.tracker.model
        starts: dict[str, FloatArray] = {'last': self.tracker.history[-1]}
        starts.update(turned_hypotheses(first.fit.theta, model))
        starts.update(finger_hypotheses(first.fit.theta, model))
        if self._trusted is not None:
            starts['trusted'] = self._trusted
            starts.update({f'trusted_{k}': v
                           for k, v in turned_hypotheses(self._trusted, model).items()})
        # Last: a live frame's budget ends before them, as before they were added.
        starts.update(swapped_fingers(first.fit.theta, model))
        return self._best_of(first, starts, observations, timings, budget_end)

    def _best_of(self, first: _Judged, starts: dict[str, FloatArray],
                 observations: FrameObservations, timings: dict[str, float],
                 budget_end: float | None = None) -> tuple[_Judged, int]:
        """The more confident of ``first`` and the fit from the best of ``starts`` (name ->
        (P,)), and the iterations spent: each start gets one short round and the most
        confident of them the full schedule, within ``budget_end`` as :meth:`_recover`
        says."""
        quick, spent = None, 0
        reserve_s = first.fit.timings_s.get('fit', 0.0)
        for name, theta in starts.items():
            if (quick is not None and budget_end is not None
                    and time.monotonic() + reserve_s > budget_end):
                break
            fit = self.tracker.fit(observations, theta, plan=QUICK, separate=False)
            spent += fit.iterations
            candidate = self._judge(name, fit, observations)
            if quick is None or candidate.confidence > quick.confidence:
                quick = candidate
        assert quick is not None
        refined = self._judge(quick.name, self._fit(observations, quick.fit.theta, timings),
                              observations)
        spent += refined.fit.iterations
        return (refined if refined.confidence > first.confidence else first), spent

    def _settle(self, judged: _Judged, stamp_ns: int, continues: bool) -> TrackStatus:
        """Keep ``judged`` as the next frame's start and decide the frame's status.

        ``continues``: the fit started from the history the tracker still holds, which it then
        extends; otherwise the history restarts at the fit.
        """
        if continues:
            self.tracker.accept(judged.fit)
            self._stamps = [*self._stamps[-1:], stamp_ns]
        else:
            # Another basin: the velocity of the old history does not apply to it.
            self.tracker.reset(judged.fit.theta)
            self._stamps = [stamp_ns]
        if judged.confidence >= self.config.failure.lost_below:
            self._lost = 0
            self._trusted = judged.fit.theta.copy()
            if not self._pinned(self._trusted):
                self._unpinned = self._trusted
            return TrackStatus.TRACKING
        self._lost += 1
        LOG.debug('frame lost (confidence %.2f, %d in a row)', judged.confidence, self._lost)
        return TrackStatus.LOST


def _in_thread(function: Callable[..., _T], *args: object) -> Future[_T]:
    """``function(*args)`` run on a daemon thread of its own; its future (not an executor:
    a session has no end at which to shut one down, and a build left running at exit must not
    hold the process)."""
    future: Future[_T] = Future()

    def run() -> None:
        try:
            future.set_result(function(*args))
        except BaseException as err:  # noqa: BLE001 - handed to whoever takes the result
            future.set_exception(err)

    threading.Thread(target=run, name='hand-model', daemon=True).start()
    return future
