"""The robustness suite: random motion under harder conditions, tracked as a user would.

Unlike the ablation (:mod:`.runner`, which starts every sequence from the ground truth and
re-initialises from it), every case here runs the product's own policy: the automatic start
from the observations and the tracking session's failure detection, recovery and search
(:mod:`hand_tracker_ros.tracking.session`). Each case is a synthetic random-motion sequence
(:class:`hand_tracker_ros.synthetic.sequence.SynthConfig`) over several seeds; frames are
scored against the ground truth.

Scores of a sequence with per-frame mean 3D joint errors ``e_t`` (mm) and LOST flags ``l_t``:

- mean, p95 and max of ``e_t``, and the share of frames with ``e_t > 15``;
- LOST recall: the share of the frames with ``e_t > 30`` that are flagged LOST;
- LOST false alarms: the share of the frames with ``e_t < 10`` that are flagged LOST;
- failure episodes: a run of frames that starts when ``e_t`` exceeds 15 mm and ends at the
  first frame back under 10 mm; its length is the frames it took to recover (an episode still
  open at the end of the sequence counts as not recovered).
"""
from __future__ import annotations

import logging
import multiprocessing
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from hand_tracker_ros._typing import BoolArray, FloatArray
from hand_tracker_ros.core.frames import FrameSet
from hand_tracker_ros.evaluation.metrics import joint_errors_mm
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.pipeline.offline import OfflinePipeline, PipelineConfig
from hand_tracker_ros.status import TrackStatus
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence

LOG = logging.getLogger(__name__)
FAIL_MM, RECOVERED_MM = 15.0, 10.0
LOST_MM, RIGHT_MM = 30.0, 10.0

# name -> what differs from random motion, 300 frames, 4 x 320x240 at 30 fps.
CASES: dict[str, dict[str, Any]] = {
    'random 300': {},
    'random 600': {'n_frames': 600},
    '15 fps': {'fps': 15.0},
    '2 cameras': {'n_cameras': 2},
    'noise 12': {'noise_sigma': 12.0},
    'clutter 40': {'clutter': 40},
}


@dataclass(frozen=True, eq=False)
class CaseRun:
    """One case on one seed: per-frame errors (mm), LOST flags and processing times (s)."""

    case: str
    seed: int
    errors_mm: FloatArray     # (T,)
    lost: BoolArray           # (T,)
    seconds: FloatArray       # (T,)


def episodes(errors_mm: FloatArray) -> list[int | None]:
    """Lengths (frames) of the failure episodes of one sequence; None: not recovered."""
    out: list[int | None] = []
    start = None
    for t, e in enumerate(errors_mm):
        if start is None and e > FAIL_MM:
            start = t
        elif start is not None and e < RECOVERED_MM:
            out.append(t - start)
            start = None
    if start is not None:
        out.append(None)
    return out


def _share(flags: BoolArray, where: BoolArray) -> float:
    return float(np.mean(flags[where])) if np.any(where) else float('nan')


def scores(runs: Sequence[CaseRun]) -> dict[str, float]:
    """The module docstring's scores over all frames of ``runs`` (one case)."""
    e = np.concatenate([r.errors_mm for r in runs])
    lost = np.concatenate([r.lost for r in runs])
    eps = [n for r in runs for n in episodes(r.errors_mm)]
    closed = [n for n in eps if n is not None]
    return {
        'frames': float(e.size), 'mean_mm': float(e.mean()),
        'p95_mm': float(np.percentile(e, 95)), 'max_mm': float(e.max()),
        'over_15mm': float(np.mean(e > FAIL_MM)),
        'lost_recall': _share(lost, e > LOST_MM), 'lost_false': _share(lost, e < RIGHT_MM),
        'episodes': float(len(eps)), 'unrecovered': float(len(eps) - len(closed)),
        'recovery_median': float(np.median(closed)) if closed else float('nan'),
        'recovery_max': float(max(closed)) if closed else float('nan'),
        'ms_median': float(1e3 * np.median(np.concatenate([r.seconds for r in runs]))),
    }


def run_case(job: tuple[str, int, int | None, PipelineConfig]) -> CaseRun:
    """Track one case on one seed with auto start (a worker-process entry).

    ``job`` is ``(case, seed, frames, pipeline)``; ``frames`` overrides the case's length.
    """
    case, seed, frames, pipeline_config = job
    synth = replace(SynthConfig(motion='random', seed=seed, n_frames=300), **CASES[case])
    if frames is not None:
        synth = replace(synth, n_frames=frames)
    model = HandModel.build()
    sequence = SyntheticSequence(synth, model)
    pipeline = OfflinePipeline(model, sequence.rig, pipeline_config)
    truth: dict[int, FloatArray] = {}
    errors, lost, seconds = [], [], []

    def rendered() -> Iterator[FrameSet]:
        for frame in sequence:
            truth[frame.stamp_ns] = frame.keypoints_m
            yield FrameSet(frame.stamp_ns, frame.images)

    start = time.monotonic()
    try:
        for result in pipeline.run(rendered()):
            errors.append(joint_errors_mm(result.posed.keypoints_m[None],
                                          truth.pop(result.stamp_ns)[None])[0])
            lost.append(result.status == TrackStatus.LOST)
            seconds.append(result.timings_s['total'])
    finally:
        pipeline.close()
    errors_mm = np.array(errors)
    LOG.info('%s, seed %d: %.2f mm mean in %.0f s', case, seed, errors_mm.mean(),
             time.monotonic() - start)
    return CaseRun(case, seed, errors_mm, np.array(lost, bool), np.array(seconds))


def run_suite(cases: Sequence[str], seeds: Sequence[int], *, frames: int | None = None,
              pipeline: PipelineConfig = PipelineConfig(), workers: int = 2
              ) -> dict[str, list[CaseRun]]:
    """Every case on every seed (in ``workers`` processes); runs grouped by case."""
    jobs = [(case, seed, frames, pipeline) for case in cases for seed in seeds]
    if workers <= 1:
        runs = [run_case(job) for job in jobs]
    else:
        with multiprocessing.get_context('fork').Pool(workers) as pool:
            runs = pool.map(run_case, jobs, chunksize=1)
    return {case: [r for r in runs if r.case == case] for case in cases}


def table(results: dict[str, list[CaseRun]]) -> str:
    """A Markdown table of :func:`scores` per case."""
    head = ('| case | seeds | frames | mean (mm) | p95 | max | > 15 mm | LOST recall (> 30 mm) '
            '| LOST false (< 10 mm) | episodes (open) | recovery frames median / max | '
            'ms/frame median |\n|' + '---|' * 12)
    rows = []
    for case, runs in results.items():
        s = scores(runs)
        seeds = ', '.join(str(r.seed) for r in runs)
        rows.append(
            f"| {case} | {seeds} | {s['frames']:.0f} | {s['mean_mm']:.2f} | {s['p95_mm']:.2f} | "
            f"{s['max_mm']:.2f} | {100 * s['over_15mm']:.1f} % | {_pct(s['lost_recall'])} | "
            f"{_pct(s['lost_false'])} | {s['episodes']:.0f} ({s['unrecovered']:.0f}) | "
            f"{_num(s['recovery_median'])} / {_num(s['recovery_max'])} | {s['ms_median']:.0f} |")
    return '\n'.join([head, *rows])


def _pct(value: float) -> str:
    return 'n/a' if np.isnan(value) else f'{100 * value:.1f} %'


def _num(value: float) -> str:
    return 'n/a' if np.isnan(value) else f'{value:.0f}'
