"""Fit the hand shape to a bag: track, pick well-spread frames, fit poses and shape jointly.

Each of ``passes`` passes:

1. Track the whole bag as ``hand-tracker track`` does
   (:func:`~hand_tracker_ros.pipeline.track_bag.track_bag`). The first pass tracks the start
   shape (default: the default hand) keeping every estimate (``pipeline``: no recovery, no
   frame LOST): the evidence model judges a hand of the wrong size doubtful or LOST, and the
   default session would refit or search for it again in every frame (measured on a 1.1x
   hand: every frame LOST, 90 s for 90 frames). Later passes track the shape fitted so far
   with the tracker's own policy (``refine_pipeline``): without recovery, a grasp tracked
   with a nearly right shape drifted from 5 to 25 mm within 24 frames. Neither follows the
   hand's scale online (``session.scale``): the passes track the shape they are given.
2. Pick ``frames`` well-spread frames among the ``candidates`` share of the most confident
   ones: farthest-point sampling on the joint angles and the global rotation, from the most
   confident frame (:func:`select_frames`).
3. Observe those frames again (features and fingertip detections) and run ``rounds``
   correspondence rounds: build the model at the current shape, find every frame's
   correspondences for the image terms (:mod:`.frame_terms`), then fit all poses and the
   shape jointly (:mod:`.solver`), the prior pulling towards the start shape. The mesh is
   rebuilt at the new shape between rounds.

The result reports, for the last pass's frames, the root-mean-square residual of every image
term with the start shape (first-pass poses) and with the fitted one; the correspondences are
found on each model, so the row counts differ (the costs ``0.5 w |r|^2`` are not comparable
for that reason: a model that is too small has fewer matched rows). It also gives the
relative standard deviation of every shape field from the data alone; lengths whose standard
deviation exceeds ``warn_std_m`` and factors whose relative one exceeds ``warn_relative_std``
are named as not constrained by the sequence (their fitted value is mostly the prior's).
"""
from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hand_tracker_ros._typing import FloatArray, IntArray
from hand_tracker_ros.bags.recover import readable_bag
from hand_tracker_ros.calibration.frame_terms import FrameTerms, frame_terms
from hand_tracker_ros.calibration.solver import (
    SolverConfig,
    fit_round,
    normal_equations,
    shape_uncertainty,
)
from hand_tracker_ros.config import nested, param
from hand_tracker_ros.core.observations import FrameObservations
from hand_tracker_ros.core.result import TrackResult
from hand_tracker_ros.energies.registry import TermsConfig
from hand_tracker_ros.errors import ConfigError
from hand_tracker_ros.geometry.camera_model import Camera
from hand_tracker_ros.geometry.rig import CameraRig
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.layout import Layout
from hand_tracker_ros.model.shape import SHAPE_NAMES, HandShape
from hand_tracker_ros.pipeline.frames import frame_sets, load_rig, rig_file
from hand_tracker_ros.pipeline.offline import OfflinePipeline, PipelineConfig
from hand_tracker_ros.pipeline.track_bag import track_bag
from hand_tracker_ros.tracking.scale import ScaleConfig
from hand_tracker_ros.tracking.session import FailureConfig, SessionConfig

LOG = logging.getLogger(__name__)


def _trusting_pipeline() -> PipelineConfig:
    """The first pass's pipeline: no recovery refits, no frame LOST, the start shape kept
    (step 1)."""
    return PipelineConfig(session=SessionConfig(recovery=False,
                                                failure=FailureConfig(lost_below=0.0),
                                                scale=ScaleConfig(enabled=False)))


def _refining_pipeline() -> PipelineConfig:
    """The later passes' pipeline: the tracker's policy with the shape fitted so far kept."""
    return PipelineConfig(session=SessionConfig(scale=ScaleConfig(enabled=False)))


@dataclass(frozen=True)
class CalibrationConfig:
    """``hand-tracker calibrate``."""

    frames: int = param(10, 'frames whose poses are fitted jointly with the shape', low=1,
                        high=1000)
    rounds: int = param(5, 'correspondence rounds (model rebuilt at the new shape in '
                        'between)', low=1, high=100)
    passes: int = param(2, 'passes: the first tracks the bag with the start shape, each '
                        'further one with the shape fitted so far', low=1, high=10)
    candidates: float = param(0.5, 'share of the tracked frames, most confident first, the '
                              'frames are picked from', low=0.01, high=1.0)
    warn_std_m: float = param(0.0015, 'warn about lengths whose standard deviation from the '
                              'data alone (times the scale) exceeds this', unit='m', low=0.0,
                              high=1.0)
    warn_relative_std: float = param(0.03, 'warn about the scale and thickness factors when '
                                     'their relative standard deviation from the data alone '
                                     'exceeds this', low=0.0, high=10.0)
    solver: SolverConfig = nested(SolverConfig)
    pipeline: PipelineConfig = nested(_trusting_pipeline)
    refine_pipeline: PipelineConfig = nested(_refining_pipeline)


@dataclass(frozen=True, eq=False)
class CalibrationResult:
    """A fitted shape and how it was found.

    Attributes
    ----------
    shape, initial_shape : HandShape
    stamps_ns : tuple of int
        Stamps of the fitted frames.
    thetas : (N, P) float64
        Their fitted poses (m, rad).
    initial_rms, final_rms : dict of str to (float, int)
        Per image term, the root-mean-square residual over the frames (px for edges and
        salient points, m for the silhouette; rows with their per-row weights) and the row
        count, before and after.
    relative_std : (S,) float64
        Relative standard deviation of every shape field (SHAPE_NAMES order) from the data.
    unconstrained : tuple of str
        Fields the data do not constrain (``warn_std_m``, ``warn_relative_std``).
    tracked_frames : int
        Frames of the bag the fitted ones were picked from.
    """

    shape: HandShape
    initial_shape: HandShape
    stamps_ns: tuple[int, ...]
    thetas: FloatArray
    initial_rms: dict[str, tuple[float, int]]
    final_rms: dict[str, tuple[float, int]]
    relative_std: FloatArray
    unconstrained: tuple[str, ...]
    tracked_frames: int


def select_frames(thetas: FloatArray, confidence: FloatArray, n: int) -> IntArray:
    """Indices (<= n,) int64 of well-spread poses among ``thetas`` (K, P).

    Farthest-point sampling in the rotation and joint-angle parameters (rad), starting from
    the most confident pose (``confidence`` (K,)); returned in sequence order.
    """
    angles = thetas[:, Layout.revolute]
    chosen = [int(np.argmax(confidence))]
    gap = np.linalg.norm(angles - angles[chosen[0]], axis=1)
    while len(chosen) < min(n, len(thetas)):
        chosen.append(int(np.argmax(gap)))
        gap = np.minimum(gap, np.linalg.norm(angles - angles[chosen[-1]], axis=1))
    return np.sort(np.asarray(chosen, dtype=np.int64))


def _observe(bag: str | Path, rig: CameraRig, stamps_ns: Sequence[int], model: HandModel,
             config: PipelineConfig) -> tuple[tuple[Camera, ...], tuple[FrameObservations, ...]]:
    """The cameras the observations are in (the working resolution's) and the features and
    detections of the frame sets at ``stamps_ns`` (in that order)."""
    wanted, found = set(stamps_ns), {}
    pipeline = OfflinePipeline(model, rig, config)
    try:
        with readable_bag(bag) as readable:
            for frames in frame_sets(readable, rig):
                if frames.stamp_ns in wanted:
                    found[frames.stamp_ns] = pipeline.observe(frames)[0]
    finally:
        pipeline.close()
    return pipeline.cameras, tuple(found[s] for s in stamps_ns)


@dataclass(frozen=True, eq=False)
class _Picked:
    """The observed frames of one pass."""

    cameras: tuple[Camera, ...]
    observations: tuple[FrameObservations, ...]
    terms: TermsConfig

    def at(self, poses: FloatArray, x: FloatArray) -> list[FrameTerms]:
        """Their image terms, corresponded on the model of shape ``x`` at ``poses`` (N, P)."""
        model = HandModel.build(HandShape.from_vector(x))
        return frame_terms(model, self.cameras, self.observations, poses, self.terms)


def _rms(frames: Sequence[FrameTerms], thetas: FloatArray, x: FloatArray
         ) -> dict[str, tuple[float, int]]:
    """Per term, the RMS residual over all frames and the row count."""
    squares = [f.squares(t, x) for f, t in zip(frames, thetas)]
    out = {}
    for name in squares[0]:
        total, rows = sum(s[name][0] for s in squares), sum(s[name][1] for s in squares)
        out[name] = (float(np.sqrt(total / rows)) if rows else 0.0, rows)
    return out


def unconstrained_fields(relative_std: FloatArray, x: FloatArray, config: CalibrationConfig
                         ) -> tuple[str, ...]:
    """Names of the shape fields the data do not constrain: lengths whose standard
    deviation, times the scale ``x[0]``, exceeds ``warn_std_m``, and the factors (scale,
    thickness) whose relative one exceeds ``warn_relative_std``; ``relative_std`` and ``x``
    are (S,) float64."""
    limit = np.where([n.endswith('_m') for n in SHAPE_NAMES],
                     config.warn_std_m / np.abs(x * x[0]), config.warn_relative_std)
    return tuple(n for n, s, lim in zip(SHAPE_NAMES, relative_std, limit) if not s <= lim)


def _track(bag: str | Path, rig_path: Path, config: PipelineConfig, shape: HandShape
           ) -> list[TrackResult]:
    tracked = [f.result for f in track_bag(bag, rig_path=rig_path, config=config,
                                           shape=shape)]
    if not tracked:
        msg = f'{bag}: no synchronized frame set; nothing to calibrate from'
        raise ConfigError(msg)
    return tracked


def _pick(tracked: Sequence[TrackResult], config: CalibrationConfig
          ) -> tuple[tuple[int, ...], FloatArray, int]:
    """Stamps and poses (N, P) of the picked frames, and the number of candidates."""
    ranked = sorted(tracked, key=lambda r: -r.confidence)
    good = sorted(ranked[:max(1, round(config.candidates * len(ranked)))],
                  key=lambda r: r.stamp_ns)
    pick = select_frames(np.stack([r.theta for r in good]),
                         np.array([r.confidence for r in good]), config.frames)
    return (tuple(good[i].stamp_ns for i in pick), np.stack([good[i].theta for i in pick]),
            len(good))


def calibrate_bag(bag: str | Path, *, rig_path: str | Path | None = None,
                  config: CalibrationConfig = CalibrationConfig(),
                  initial: HandShape = HandShape()) -> CalibrationResult:
    """Fit the hand shape to ``bag`` (see the module docstring).

    Raises
    ------
    ConfigError
        When the bag has no frame set.
    """
    rig_path = rig_file(bag, rig_path)
    with readable_bag(bag) as readable:
        rig = load_rig(readable, rig_path)
    x_bar = initial.to_vector()
    x = x_bar.copy()
    tracked = _track(bag, rig_path, config.pipeline, initial)
    start_poses = {r.stamp_ns: r.theta for r in tracked}
    for p in range(config.passes):
        if p > 0:
            tracked = _track(bag, rig_path, config.refine_pipeline, HandShape.from_vector(x))
        stamps, thetas, n_candidates = _pick(tracked, config)
        cameras, observed = _observe(bag, rig, stamps, HandModel.build(initial),
                                     config.pipeline)
        picked = _Picked(cameras, observed, config.pipeline.tracker.terms)
        for r in range(config.rounds):
            frames = picked.at(thetas, x)
            thetas, x, _ = fit_round(frames, thetas, x, x_bar, frames[0].model.lower,
                                     frames[0].model.upper, config.solver)
            LOG.info('calibration pass %d round %d: scale %.4f', p + 1, r + 1, x[0])
    before = np.stack([start_poses[s] for s in stamps])
    frames = picked.at(thetas, x)
    ne = normal_equations(frames, thetas, x, x_bar, config.solver.prior_weight * len(frames))
    std = shape_uncertainty(ne, x)
    return CalibrationResult(HandShape.from_vector(x), initial, stamps, thetas,
                             _rms(picked.at(before, x_bar), before, x_bar),
                             _rms(frames, thetas, x), std, unconstrained_fields(std, x, config),
                             n_candidates)
