"""Per-frame model fitting: warm start, coarse-to-fine rounds, separation.

For every synchronized frame set the tracker starts from the previous estimate and runs the
rounds of :mod:`.schedule`. Each round poses the model, renders it into every camera
(:func:`.views.model_views`), lets every enabled energy find its correspondences (edge matches,
flow targets, the fingertip assignment, colliding triangle pairs, limit activity, ...) and runs
box-constrained Levenberg-Marquardt (:mod:`hand_tracker_ros.optim.lm`) on the weighted sum
(:mod:`.problem`) with those correspondences fixed. The cone-field constraints of a frame's
earlier rounds stay in its later ones (``RoundContext.collisions``). While non-adjacent parts
of the fitted estimate still intersect, separation rounds (:mod:`.separation`) push them
apart.

A fit changes nothing in the tracker: :meth:`HandTracker.accept` makes it the previous frame
of the next one. Whether to accept it, and when to look for the hand elsewhere, is the
tracking session's policy (:mod:`.session`).

References: docs/references.md.
"""
from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.config import nested, param
from hand_tracker_ros.core.context import CollisionPairs, PreviousFrame, RoundContext
from hand_tracker_ros.core.energy import PreparesFrames, Term
from hand_tracker_ros.core.observations import FrameObservations
from hand_tracker_ros.core.views import (
    ModelView,
    contour_shift_px,
    model_views,
    moved_views,
)
from hand_tracker_ros.energies import flow
from hand_tracker_ros.energies.registry import TermsConfig, build_terms
from hand_tracker_ros.geometry.camera_model import Camera
from hand_tracker_ros.model.hand import HandModel, PosedHand
from hand_tracker_ros.model.layout import Layout
from hand_tracker_ros.optim.lm import FitStatus, LMConfig, levenberg_marquardt
from hand_tracker_ros.optim.pso import PSOConfig, particle_swarm
from hand_tracker_ros.render.contours import model_edges
from hand_tracker_ros.tracking.problem import Problem
from hand_tracker_ros.tracking.schedule import Round, ScheduleConfig, rounds
from hand_tracker_ros.tracking.separation import SeparationConfig, Separator


@dataclass(frozen=True)
class TrackerConfig:
    """Everything the model fit needs."""

    solver: str = param('lm', 'Levenberg-Marquardt (the method) or PSO (the HOPE baseline)',
                        choices=('lm', 'pso'))
    carry_views_px: float = param(1.0, "a fit ends with its last round's views carried to the "
                                  'estimate when their contour moved at most this much in that '
                                  'round (the median per camera, the largest camera), else '
                                  'renders them again (0: unless nothing moved)', unit='px',
                                  low=0.0, high=100.0)
    schedule: ScheduleConfig = nested(ScheduleConfig)
    separation: SeparationConfig = nested(SeparationConfig)
    lm: LMConfig = nested(LMConfig)
    pso: PSOConfig = nested(PSOConfig)
    terms: TermsConfig = nested(TermsConfig)


@dataclass(frozen=True, eq=False)
class Fit:
    """The model fitted to one frame set from one start.

    Attributes
    ----------
    theta : (P,) float64
        The estimate (m, rad; :mod:`hand_tracker_ros.model.layout`).
    posed : PosedHand
        The model posed at ``theta``.
    views : tuple of ModelView
        Its rendering in every camera: after two or more rounds the views the last round
        started from, carried to ``theta`` (:func:`~hand_tracker_ros.core.views.moved_views`)
        when that round moved their contour at most ``carry_views_px``; otherwise rendered
        at ``theta``.
    iterations : int
        LM iterations over all rounds and separation rounds.
    energy_costs : dict of str to float
        ``0.5 * w * |r|^2`` per term at the estimate, with the last round's correspondences.
    labels : tuple of tuple
        The ``labels`` of every round correspondence that has them, in term order (the
        salient term: per camera, detection -> finger, -1 unassigned; the limits term: the
        active constraints).
    timings_s : dict of str to float
        Wall time of each stage (s).
    lm_statuses : tuple of FitStatus
        Why each Levenberg-Marquardt call stopped, in order: the rounds, then the separation
        rounds (empty for PSO).
    """

    theta: FloatArray
    posed: PosedHand
    views: tuple[ModelView, ...]
    iterations: int
    energy_costs: dict[str, float]
    labels: tuple[tuple[object, ...], ...] = ()
    timings_s: dict[str, float] = field(default_factory=dict)
    lm_statuses: tuple[FitStatus, ...] = ()


class HandTracker:
    """Tracks one hand through a sequence of frame sets."""

    def __init__(self, model: HandModel, cameras: Sequence[Camera],
                 config: TrackerConfig = TrackerConfig()) -> None:
        self.cameras = tuple(cameras)
        self.config = config
        self._rounds = rounds(config.schedule)
        self._previous: PreviousFrame | None = None
        self._build(model)

    def _build(self, model: HandModel) -> None:
        """Everything that depends on the model."""
        self.model = model
        self._terms = build_terms(self.config.terms, model)
        self._separator = Separator(model, self._terms, self.config.separation, self.config.lm)

    def reshape(self, model: HandModel) -> None:
        """Track ``model``, the hand at another shape, from the next fit on; the history
        is kept, posed on it."""
        self._build(model)
        if self._previous is not None:
            thetas = self._previous.thetas
            posed = model.pose(thetas[-1], jacobian=False)
            self._previous = PreviousFrame(posed, self.views(posed), thetas)

    @property
    def terms(self) -> tuple[Term, ...]:
        """The enabled energy terms, built for the model."""
        return tuple(self._terms)

    @property
    def initialized(self) -> bool:
        """True once a pose has been set or found."""
        return self._previous is not None

    def views(self, posed: PosedHand) -> tuple[ModelView, ...]:
        """The model ``posed`` (this tracker's or, after :meth:`reshape`, an earlier one)
        rendered into every camera."""
        return model_views(posed, model_edges(posed.model), self.cameras)

    def prepare(self, observations: FrameObservations) -> None:
        """The terms' per-frame work that needs no pose (:class:`PreparesFrames`), for the
        thread that observes a set to call before handing it to :meth:`fit`; a set that skips
        this is fitted the same, doing that work in its first round."""
        for term in self._terms:
            if isinstance(term.energy, PreparesFrames):
                term.energy.prepare(observations)

    def reset(self, theta: FloatArray | None = None) -> None:
        """Forget the history; start from ``theta`` (or wait for an initialization)."""
        if theta is None:
            self._previous = None
            return
        theta = np.clip(np.asarray(theta, np.float64), self.model.lower, self.model.upper)
        posed = self.model.pose(theta, jacobian=False)
        self._previous = PreviousFrame(posed, self.views(posed), theta[None].copy())

    def _solve_round(self, theta: FloatArray, free: np.ndarray, use_flow: bool,
                     observations: FrameObservations, timings: dict[str, float],
                     start_views: tuple[ModelView, ...] | None,
                     collisions: CollisionPairs | None, statuses: list[FitStatus]
                     ) -> tuple[FloatArray, int, Problem, tuple[object, ...],
                                tuple[ModelView, ...]]:
        """One round from ``theta``: views (``start_views`` if given), correspondences and LM;
        returns the estimate, its iterations, the problem, the correspondences and the views
        the round started from."""
        start = time.perf_counter()
        posed = self.model.pose(theta, jacobian=False)
        views = start_views if start_views is not None else self.views(posed)
        context = RoundContext(posed, views, observations, self._previous, collisions)
        terms = [t for t in self._terms if use_flow or t.name != flow.NAME]
        problem = Problem(self.model, terms)
        mid = time.perf_counter()
        correspondences = []
        for term in problem.terms:
            t0 = time.perf_counter()
            correspondences.append(term.energy.correspond(context))
            key = f'correspond.{term.name}'
            timings[key] = timings.get(key, 0.0) + time.perf_counter() - t0
        timings['views'] = timings.get('views', 0.0) + mid - start
        t0 = time.perf_counter()
        result = levenberg_marquardt(problem.function(correspondences), theta,
                                     self.model.lower, self.model.upper, free=free,
                                     config=self._lm_config(), angular=Layout.revolute)
        timings['solve'] = timings.get('solve', 0.0) + time.perf_counter() - t0
        statuses.append(result.status)
        return result.x, result.n_iterations, problem, tuple(correspondences), views

    def _solve_pso(self, theta: FloatArray, observations: FrameObservations,
                   timings: dict[str, float]
                   ) -> tuple[FloatArray, int, Problem, tuple[object, ...]]:
        """The HOPE baseline: PSO on the same objective, re-anchored every generation."""
        problem = Problem(self.model, self._terms)
        anchor_corrs: list[tuple[object, ...]] = []

        def cost_at(anchor: FloatArray) -> Callable[[FloatArray], FloatArray]:
            posed = self.model.pose(anchor, jacobian=False)
            context = RoundContext(posed, self.views(posed), observations, self._previous)
            anchor_corrs.append(problem.correspond(context))
            fun = problem.function(anchor_corrs[-1])
            return lambda X: np.array([0.5 * float(r @ r) for r in (fun(x, False)[0] for x in X)])

        start = time.perf_counter()
        # HOPE's per-parameter spreads: 10 mm for the position, 0.1 for every angle.
        spread = np.where(Layout.prismatic, 0.01, 0.1)
        result = particle_swarm(cost_at, theta, self.model.lower, self.model.upper, spread,
                                config=self.config.pso)
        timings['solve'] = time.perf_counter() - start
        return result.x, result.evaluations, problem, anchor_corrs[-1]

    def _lm_config(self) -> LMConfig:
        """The LM settings of a round: ``schedule.iterations``, capped by ``lm.max_iterations``."""
        lm = self.config.lm
        return dataclasses.replace(lm, max_iterations=min(self.config.schedule.iterations,
                                                          lm.max_iterations))

    def fit(self, observations: FrameObservations, start: FloatArray | None = None, *,
            plan: Sequence[Round] | None = None, separate: bool = True,
            deadline_s: float | None = None) -> Fit:
        """Fit the model to one frame set from ``start`` (default: the previous estimate).

        ``plan`` replaces the configured rounds (e.g. one short round to rank hypotheses);
        ``separate=False`` skips the separation rounds. Once a round with every parameter
        free has run, a round that would end after ``deadline_s`` (``time.monotonic``;
        judged by the previous round's duration) is not started: a live tracker keeps to
        its frame budget with the rounds done so far (a coarse round alone leaves the distal
        joints where they were, which drifts within a few frames). The tracker's history is
        not changed: :meth:`accept` makes a fit the previous frame of the next one. Requires
        a history (``reset``), which the flow and temporal terms read.
        """
        if self._previous is None:
            msg = 'tracker is not initialized: call reset(theta) first'
            raise RuntimeError(msg)
        begin = time.perf_counter()
        timings: dict[str, float] = {}
        theta = (self._previous.thetas[-1] if start is None
                 else np.clip(np.asarray(start, np.float64), self.model.lower, self.model.upper))
        theta = theta.copy()
        iterations = 0
        statuses: list[FitStatus] = []
        problem: Problem | None = None
        correspondences: tuple[object, ...] = ()
        if self.config.solver == 'pso':
            theta, iterations, problem, correspondences = self._solve_pso(theta, observations,
                                                                         timings)
        # A round that starts at the previous estimate reuses its rendered views.
        start_views = self._previous.views if start is None else None
        collisions: CollisionPairs | None = None     # the frame's constraints so far
        plan = self._rounds if plan is None else plan
        round_s, full_done = 0.0, False
        # The views the last round started from, when an earlier round of this fit led there.
        last_views: tuple[ModelView, ...] | None = None
        for n_round, rnd in enumerate(plan if self.config.solver == 'lm' else ()):
            if full_done and deadline_s is not None and time.monotonic() + round_s > deadline_s:
                break
            round_start = time.monotonic()
            theta, n_iter, problem, correspondences, round_views = self._solve_round(
                theta, rnd.free, rnd.use_flow, observations, timings, start_views, collisions,
                statuses)
            last_views = round_views if n_round > 0 else None
            found = dict(zip(problem.names, correspondences)).get('collision')
            collisions = found if isinstance(found, CollisionPairs) else None
            start_views = None
            iterations += n_iter
            round_s = time.monotonic() - round_start
            full_done = full_done or bool(rnd.free.all())
        separated_iterations = 0
        if self.config.solver == 'lm' and separate:
            t0 = time.perf_counter()
            separated = self._separator.separate(theta, collisions)
            timings['separation'] = time.perf_counter() - t0
            theta, posed = separated.theta, separated.posed
            separated_iterations = separated.iterations
            iterations += separated.iterations
            statuses += separated.statuses
        else:
            posed = self.model.pose(theta, jacobian=False)
        assert problem is not None
        t0 = time.perf_counter()
        # After an earlier round the last one usually moves the hand a fraction of a pixel:
        # its views carried to the estimate. Rendered at the estimate when it moved more,
        # after a single round (a short fit from a hypothesis, which moves the hand far, or a
        # one-round schedule, which would carry the same raster from set to set), after a
        # separation round, and for PSO.
        if (last_views is not None and separated_iterations == 0
                and contour_shift_px(last_views, posed) <= self.config.carry_views_px):
            views = moved_views(last_views, posed)
        else:
            views = self.views(posed)
        timings['views'] = timings.get('views', 0.0) + time.perf_counter() - t0
        labels = tuple(getattr(c, 'labels', ()) for c in correspondences
                       if hasattr(c, 'labels'))
        costs = problem.costs(theta, correspondences)
        timings['fit'] = time.perf_counter() - begin
        return Fit(theta, posed, views, iterations, costs, labels, timings, tuple(statuses))

    def accept(self, fit: Fit) -> None:
        """Make ``fit`` the previous frame of the next fit (the temporal history grows)."""
        assert self._previous is not None
        history = np.vstack([self._previous.thetas, fit.theta[None]])[-2:]
        self._previous = PreviousFrame(fit.posed, fit.views, history)

    @property
    def last_posed(self) -> PosedHand | None:
        """The model posed at the last accepted estimate; None before a reset."""
        return None if self._previous is None else self._previous.posed

    @property
    def history(self) -> FloatArray:
        """The accepted estimates, oldest first, (K, P) with K <= 2; (0, P) before a reset."""
        if self._previous is None:
            return np.zeros((0, Layout.P))
        return self._previous.thetas
