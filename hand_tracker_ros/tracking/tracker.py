"""Per-frame model fitting: warm start, coarse-to-fine rounds, failure detection.

For every synchronized frame set the tracker starts from the previous estimate and runs the
rounds of :mod:`.schedule`. Each round poses the model, renders it into every camera
(:func:`.views.model_views`), lets every enabled energy find its correspondences (edge matches,
flow targets, the fingertip assignment, colliding triangle pairs, limit activity, ...) and runs
box-constrained Levenberg-Marquardt (:mod:`hand_tracker_ros.optim.lm`) on the weighted sum
(:mod:`.problem`) with those correspondences fixed. The cone-field constraints of a frame's
earlier rounds stay in its later ones (``RoundContext.collisions``). While non-adjacent parts
of the fitted estimate still intersect, separation rounds (:mod:`.separation`) push them
apart.

After the last round the estimate is checked (:mod:`.health`): a non-finite result or a model
silhouette that is no longer covered by the observed foreground masks marks the frame LOST;
nothing is published as tracking then, and after ``failure.reinit_after`` lost frames the tracker
re-initialises from the observations (:mod:`.initialize`).
"""
from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Any

import numpy as np

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.config import nested, param
from hand_tracker_ros.energies.collision import CollisionPairs
from hand_tracker_ros.geometry.camera import PinholeCamera
from hand_tracker_ros.model.hand import HandModel, PosedHand
from hand_tracker_ros.model.layout import Layout
from hand_tracker_ros.optim.lm import LMConfig, levenberg_marquardt
from hand_tracker_ros.optim.pso import PSOConfig, particle_swarm
from hand_tracker_ros.render.contours import MeshEdges
from hand_tracker_ros.tracking.energies import TermsConfig, build_terms
from hand_tracker_ros.tracking.health import FailureConfig, silhouette_coverage
from hand_tracker_ros.tracking.observations import FrameObservations
from hand_tracker_ros.tracking.problem import Problem
from hand_tracker_ros.tracking.schedule import ScheduleConfig, rounds
from hand_tracker_ros.tracking.separation import SeparationConfig, Separator
from hand_tracker_ros.tracking.views import ModelView, PreviousFrame, RoundContext, model_views

LOG = logging.getLogger(__name__)


class TrackStatus(IntEnum):
    """Matches ``hand_tracker_msgs/HandState`` STATUS_* constants."""

    INITIALIZING = 0
    TRACKING = 1
    LOST = 2


@dataclass(frozen=True)
class TrackerConfig:
    """Everything the tracking loop needs."""

    solver: str = param('lm', 'Levenberg-Marquardt (the method) or PSO (the HOPE baseline)',
                        choices=('lm', 'pso'))
    schedule: ScheduleConfig = nested(ScheduleConfig)
    separation: SeparationConfig = nested(SeparationConfig)
    lm: LMConfig = nested(LMConfig)
    pso: PSOConfig = nested(PSOConfig)
    terms: TermsConfig = nested(TermsConfig)
    failure: FailureConfig = nested(FailureConfig)


@dataclass(frozen=True, eq=False)
class TrackResult:
    """The estimate of one frame."""

    stamp_ns: int
    status: TrackStatus
    theta: FloatArray                  # (P,)
    posed: PosedHand
    iterations: int                    # LM iterations over all rounds
    energy_costs: dict[str, float]     # 0.5 * w * |r|^2 per term at the estimate
    silhouette_coverage: float         # mean fraction of the model silhouette on foreground
    timings_s: dict[str, float] = field(default_factory=dict)
    labels: tuple[Any, ...] = ()       # per camera: detection -> finger (-1 unassigned)


class HandTracker:
    """Tracks one hand through a sequence of frame sets."""

    def __init__(self, model: HandModel, cameras: Sequence[PinholeCamera],
                 config: TrackerConfig = TrackerConfig()) -> None:
        self.model = model
        self.cameras = tuple(cameras)
        self.config = config
        self._edges = MeshEdges.from_faces(model.faces)
        self._terms = build_terms(config.terms, model)
        self._separator = Separator(model, self._terms, config.separation, self._lm_config())
        self._rounds = rounds(config.schedule)
        self._previous: PreviousFrame | None = None
        self._lost_frames = 0

    @property
    def initialized(self) -> bool:
        """True once a pose has been set or found."""
        return self._previous is not None

    def views(self, posed: PosedHand) -> tuple[ModelView, ...]:
        """The model rendered into every camera."""
        return model_views(posed, self.model.faces, self._edges, self.cameras)

    def reset(self, theta: FloatArray | None = None) -> None:
        """Forget the history; start from ``theta`` (or wait for an initialization)."""
        self._lost_frames = 0
        if theta is None:
            self._previous = None
            return
        theta = np.clip(np.asarray(theta, np.float64), self.model.lower, self.model.upper)
        posed = self.model.pose(theta, jacobian=False)
        self._previous = PreviousFrame(posed, self.views(posed), theta[None].copy())

    def _solve_round(self, theta: FloatArray, free: np.ndarray, use_flow: bool,
                     observations: FrameObservations, timings: dict[str, float],
                     start_views: tuple[ModelView, ...] | None,
                     collisions: CollisionPairs | None
                     ) -> tuple[FloatArray, int, Problem, tuple[Any, ...]]:
        start = time.perf_counter()
        posed = self.model.pose(theta, jacobian=False)
        views = start_views if start_views is not None else self.views(posed)
        context = RoundContext(posed, views, observations, self._previous, collisions)
        terms = [t for t in self._terms if use_flow or t.name != 'flow']
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
        return result.x, result.n_iterations, problem, tuple(correspondences)

    def _solve_pso(self, theta: FloatArray, observations: FrameObservations,
                   timings: dict[str, float]) -> tuple[FloatArray, int, Problem, tuple[Any, ...]]:
        """The HOPE baseline: PSO on the same objective, re-anchored every generation."""
        problem = Problem(self.model, self._terms)
        anchor_corrs: list[tuple[Any, ...]] = []

        def cost_at(anchor: FloatArray) -> Any:
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
        lm = self.config.lm
        return LMConfig(max_iterations=self.config.schedule.iterations, tau=lm.tau,
                        ftol=lm.ftol, xtol=lm.xtol, max_mean_step_rad=lm.max_mean_step_rad,
                        max_damping=lm.max_damping)

    def track(self, observations: FrameObservations) -> TrackResult:
        """Fit the model to one frame set; the tracker must be initialized (see ``reset``)."""
        if self._previous is None:
            msg = 'tracker is not initialized: call reset(theta) or initialize first'
            raise RuntimeError(msg)
        start = time.perf_counter()
        timings: dict[str, float] = {}
        theta = self._previous.thetas[-1].copy()
        iterations = 0
        problem, correspondences = None, ()
        if self.config.solver == 'pso':
            theta, iterations, problem, correspondences = self._solve_pso(theta, observations,
                                                                         timings)
        # The first round starts at the previous estimate, whose views are already rendered.
        start_views: tuple[ModelView, ...] | None = self._previous.views
        collisions: CollisionPairs | None = None     # the frame's constraints so far
        for rnd in self._rounds if self.config.solver == 'lm' else ():
            theta, n_iter, problem, correspondences = self._solve_round(
                theta, rnd.free, rnd.use_flow, observations, timings, start_views, collisions)
            collisions = dict(zip(problem.names, correspondences)).get('collision')
            start_views = None
            iterations += n_iter
        if self.config.solver == 'lm':
            t0 = time.perf_counter()
            separated = self._separator.separate(theta, collisions)
            timings['separation'] = time.perf_counter() - t0
            theta, posed = separated.theta, separated.posed
            iterations += separated.iterations
        else:
            posed = self.model.pose(theta, jacobian=False)
        assert problem is not None
        views = self.views(posed)
        coverage = silhouette_coverage(views, observations)
        healthy = (bool(np.all(np.isfinite(theta)))
                   and coverage >= self.config.failure.min_coverage)
        costs = problem.costs(theta, correspondences)
        labels = tuple(getattr(c, 'labels', ()) for c in correspondences
                       if hasattr(c, 'labels'))
        if healthy:
            self._lost_frames = 0
            history = np.vstack([self._previous.thetas, theta[None]])[-2:]
            self._previous = PreviousFrame(posed, views, history)
            status = TrackStatus.TRACKING
        else:
            self._lost_frames += 1
            status = TrackStatus.LOST
            LOG.warning('frame %d lost (silhouette coverage %.2f)', observations.stamp_ns,
                        coverage)
        timings['total'] = time.perf_counter() - start
        return TrackResult(observations.stamp_ns, status, theta, posed, iterations, costs, coverage,
                           timings, labels)

    @property
    def lost_frames(self) -> int:
        """Consecutive frames judged lost."""
        return self._lost_frames
