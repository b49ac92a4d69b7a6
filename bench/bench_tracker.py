"""Per-frame cost of the full method, split by stage, at 4 x 320x240 and 4 x 640x480.

Usage: python bench/bench_tracker.py [--frames N] [--pso]
Stages: features (edges, mask, flow; 2-thread pool), detection, views (render + contours of the
model in every camera, per round), correspondences per term (collision = triangle-pair search),
LM solves; medians over the frames after a warm-up frame, each set observed and fitted in turn
(``OfflinePipeline.step``: ``total`` is the latency of one set). Then the wall time per frame of
``OfflinePipeline.run``, which observes set k+1 while fitting set k (what ``hand-tracker track``
does, and what the node graph does across processes): the same estimates, checked here,
and the fitting thread's CPU time per set there (against the serial ``fit``: what the
observation of the next set on the other core costs the fit).
"""
from __future__ import annotations

import argparse
import statistics
import time
from collections import defaultdict

import numpy as np

from hand_tracker_ros.config import from_mapping
from hand_tracker_ros.core.frames import FrameSet
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.pipeline.offline import OfflinePipeline, PipelineConfig
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence


def bench(width: int, height: int, frames: int, overrides: dict) -> None:
    model = HandModel.build()
    seq = SyntheticSequence(SynthConfig(motion='random', n_frames=frames + 2, width=width,
                                        height=height), model)
    shots = [seq.frame(k) for k in range(frames + 2)]
    sets = [FrameSet(shot.stamp_ns, shot.images) for shot in shots]
    config = from_mapping(PipelineConfig, overrides)
    pipe = OfflinePipeline(model, seq.rig, config)
    pipe.session.reset(shots[0].theta)
    pipe.step(sets[1])  # warm-up (numba caches, pools)
    stages = defaultdict(list)
    serial = []
    for frame_set in sets[2:]:
        result = pipe.step(frame_set)
        serial.append(result.theta)
        for key, seconds in result.timings_s.items():
            stages[key].append(1e3 * seconds)
    pipe.close()
    label = overrides.get('tracker.solver', 'lm')
    print(f'\n{label} at 4 x {width}x{height}, {frames} frames (median ms per frame):')
    for key in sorted(stages, key=lambda k: (k == 'total', k)):
        values = stages[key]
        print(f'  {key:24s} {statistics.median(values):7.1f}   (min {min(values):.1f}, '
              f'max {max(values):.1f})')

    pipe = OfflinePipeline(model, seq.rig, config)
    pipe.session.reset(shots[0].theta)
    pipe.step(sets[1])
    walls, fit_cpu, pipelined = [], [], []
    start, start_cpu = time.perf_counter(), time.thread_time()
    for result in pipe.run(sets[2:]):      # the fits run on this thread, the observations not
        now, now_cpu = time.perf_counter(), time.thread_time()
        walls.append(1e3 * (now - start))
        fit_cpu.append(1e3 * (now_cpu - start_cpu))
        pipelined.append(result.theta)
        start, start_cpu = now, now_cpu
    pipe.close()
    same = np.array_equal(np.array(serial), np.array(pipelined))
    print(f'  {"pipelined wall":24s} {statistics.median(walls):7.1f}   (min {min(walls):.1f}, '
          f'max {max(walls):.1f}; estimates {"identical" if same else "DIFFER"})')
    # Against the serial 'fit' above: how much the observation on the other thread slows it.
    print(f'  {"pipelined fit CPU":24s} {statistics.median(fit_cpu):7.1f}   (the fitting '
          f'thread\'s CPU time per set, beside the next set\'s observation)')


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument('--frames', type=int, default=30)
    parser.add_argument('--pso', action='store_true', help='also time the PSO baseline')
    args = parser.parse_args()
    for width, height in ((320, 240), (640, 480)):
        bench(width, height, args.frames, {})
    if args.pso:
        bench(320, 240, args.frames, {'tracker.solver': 'pso', 'tracker.pso.particles': 16,
                                      'tracker.pso.generations': 5})


if __name__ == '__main__':
    main()
