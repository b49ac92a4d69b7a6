"""Run tracking configurations on synthetic sequences and score them against ground truth.

Protocol (the same for every configuration): the tracker is initialised with the ground-truth
pose of frame 0 (as Ballan et al. initialise manually) and frame 0 primes the features; frames
1..T-1 are tracked and scored. When the tracker reports ``failure.reinit_after`` consecutive
lost frames it is re-initialised from the ground truth of the current frame (an evaluation
stand-in for re-detection); those lost frames count as failures.

References: docs/references.md.
"""
from __future__ import annotations

import logging
import multiprocessing
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.config import param
from hand_tracker_ros.core.frames import FrameSet
from hand_tracker_ros.evaluation.metrics import (
    SequenceScores,
    deepest_interpenetration_m,
    joint_errors_mm,
    score_sequence,
)
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.pipeline.offline import OfflinePipeline, PipelineConfig
from hand_tracker_ros.progress import progress
from hand_tracker_ros.status import TrackStatus
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence

LOG = logging.getLogger(__name__)


@dataclass(frozen=True)
class BenchmarkConfig:
    """The default benchmark of the tracker-core issue."""

    motions: tuple[str, ...] = param(('grasp', 'tapping', 'random'), 'scripted motions')
    n_frames: int = param(150, 'frames per sequence', low=2, high=100000)
    n_cameras: int = param(4, 'cameras of the ring rig', low=1, high=8)
    width: int = param(320, 'image width', unit='px', low=16)
    height: int = param(240, 'image height', unit='px', low=16)
    fps: float = param(30.0, 'frame rate', unit='Hz', low=1.0)
    seed: int = param(0, 'seed of the sequences and of the edge noise', low=0)


@dataclass(frozen=True)
class Job:
    """One configuration on one motion."""

    label: str
    motion: str
    pipeline: PipelineConfig
    benchmark: BenchmarkConfig


@dataclass(frozen=True, eq=False)
class RunResult:
    """Scores and per-frame series of one job."""

    label: str
    motion: str
    scores: SequenceScores
    errors_mm: FloatArray      # (T-1,) per-frame mean joint error
    lost: FloatArray           # (T-1,) bool


def run_job(job: Job) -> RunResult:
    """Track one synthetic sequence with one configuration (a worker-process entry)."""
    bench = job.benchmark
    model = HandModel.build()
    sequence = SyntheticSequence(SynthConfig(
        motion=job.motion, n_frames=bench.n_frames, fps=bench.fps, n_cameras=bench.n_cameras,
        width=bench.width, height=bench.height, seed=bench.seed), model)
    pipeline = OfflinePipeline(model, sequence.rig, job.pipeline)
    truth, estimate, lost, seconds, depth = [], [], [], [], []
    first = sequence.frame(0)
    pipeline.session.reset(first.theta)
    pipeline.observe(FrameSet(first.stamp_ns, first.images))
    for k in range(1, len(sequence)):
        frame = sequence.frame(k)
        result = pipeline.step(FrameSet(frame.stamp_ns, frame.images))
        truth.append(frame.keypoints_m)
        estimate.append(result.posed.keypoints_m)
        lost.append(result.status == TrackStatus.LOST)
        seconds.append(result.timings_s['total'])
        depth.append(deepest_interpenetration_m(result.posed))
        if pipeline.session.lost_frames >= job.pipeline.session.failure.reinit_after:
            pipeline.session.reset(frame.theta)
    pipeline.close()
    est, tru = np.array(estimate), np.array(truth)
    scores = score_sequence(est, tru, lost, sequence.rig.cameras, depth, seconds)
    LOG.info('%s on %s: %.2f mm mean, %.0f ms/frame', job.label, job.motion,
             scores.joint_mean_mm, scores.ms_per_frame)
    return RunResult(job.label, job.motion, scores, joint_errors_mm(est, tru),
                     np.array(lost, bool))


def run_jobs(jobs: Sequence[Job], workers: int = 2) -> list[RunResult]:
    """Run jobs in ``workers`` processes (1: in this process), results in job order."""
    def bar(results: Iterable[RunResult]) -> list[RunResult]:
        return list(progress(results, total=len(jobs), desc='evaluate', unit='run'))

    if workers <= 1:
        return bar(run_job(job) for job in jobs)
    with multiprocessing.get_context('fork').Pool(workers) as pool:
        return bar(pool.imap(run_job, jobs, chunksize=1))
