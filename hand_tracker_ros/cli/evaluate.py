"""`hand-tracker evaluate`: the ablation of the method on synthetic sequences.

Runs LO+E, LO+EC, LO+ECO, LO+ECOS, the full method and the PSO baseline on the default
benchmark (4 cameras, 320x240, 30 fps, structured edge noise on; grasp, tapping and random
motions of 150 frames) and writes ``ablation.md``, ``ablation.json`` and
``ablation_error.png``; then the full method under several LM schedules
(``tradeoff.*``: error vs ms per frame).

References: docs/references.md.
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

from hand_tracker_ros.evaluation.presets import NAMES, preset
from hand_tracker_ros.evaluation.report import write_report
from hand_tracker_ros.evaluation.runner import BenchmarkConfig, Job, run_jobs
from hand_tracker_ros.pipeline.offline import PipelineConfig
from hand_tracker_ros.synthetic.edge_noise import EdgeNoiseConfig

# (coarse rounds, full rounds, LM iterations per round); Ballan's is (10, 20, 10).
SCHEDULES = ((0, 1, 4), (0, 2, 4), (1, 3, 4), (1, 4, 8))   # the default 1+2x4 is `full`


def add_parser(sub: Any) -> None:
    """Register the verb."""
    parser = sub.add_parser('evaluate', help='run the ablation on synthetic sequences',
                            description=__doc__)
    parser.add_argument('--out', default='out/evaluation', help='output directory')
    parser.add_argument('--frames', type=int, default=150, help='frames per sequence')
    parser.add_argument('--motions', nargs='+', default=list(BenchmarkConfig().motions))
    parser.add_argument('--configs', nargs='+', default=list(NAMES), choices=NAMES)
    parser.add_argument('--no-tradeoff', action='store_true', help='skip the schedule sweep')
    parser.add_argument('--workers', type=int, default=2, help='processes (default 2)')
    parser.add_argument('--seed', type=int, default=0)
    parser.set_defaults(run=run)


def _base() -> PipelineConfig:
    return PipelineConfig(edge_noise=EdgeNoiseConfig(enabled=True))


def run(args: argparse.Namespace) -> int:
    """Run the jobs and print the tables."""
    bench = BenchmarkConfig(motions=tuple(args.motions), n_frames=args.frames, seed=args.seed)
    base = _base()
    jobs = [Job(name, motion, preset(name, base), bench)
            for name in args.configs for motion in bench.motions]
    start = time.monotonic()
    out = Path(args.out)
    print(write_report(run_jobs(jobs, args.workers), out, 'ablation'))
    if not args.no_tradeoff:
        jobs = [Job(f'schedule {c}+{f}x{i}', motion, preset('full', base, {
            'tracker.schedule.coarse_rounds': c, 'tracker.schedule.full_rounds': f,
            'tracker.schedule.iterations': i}), bench)
                for c, f, i in SCHEDULES for motion in bench.motions]
        print(write_report(run_jobs(jobs, args.workers), out, 'tradeoff'))
    print(f'wrote {out}/ablation.{{md,json}}, ablation_error.png'
          f"{'' if args.no_tradeoff else ', tradeoff.{md,json}, tradeoff_error.png'} "
          f'in {time.monotonic() - start:.0f} s')
    return 0
