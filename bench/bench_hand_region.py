"""Where the visual hull puts the hand: its centroid's miss, and the slid hypotheses' miss.

Usage: python bench/bench_hand_region.py [--seeds 3540 3541] [--motions random pinch]
       [--frames 0 30]

For each seed and motion a sequence as long as the last frame asked for (4 x 320x240, the
default clutter) is observed at those frames. One row per frame: the camera masks'
foreground shares, the distance (mm) from the hull's centroid to the hand's mesh centroid
and its component along the hull's longest axis (``tracking.initialize.HandRegion``), the
distance from the mesh centroid of the best-ranked hypothesis to the hand's, unslid
(``slide_best`` 0) and slid (the defaults), and the wall time of each ranking (ms). Then the
median, 90th percentile and maximum of each column. The twenty-first session's run
(``--seeds 3540 ... 3559``, the default motions and frames) gave: centroid miss median 11.4
mm, p90 14.1, max 26.6 (along the axis 10.4, 12.9, 26.6); the best unslid hypothesis as far;
the best slid one median 6.3, p90 18.2, max 46.6; the ranking a median of 28 ms unslid and
48 ms slid. The ranking alone can slide the wrong way; the short fits of the best 24 decide.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from hand_tracker_ros.core.frames import FrameSet
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.pipeline.offline import OfflinePipeline
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence
from hand_tracker_ros.tracking.initialize import InitConfig, VisualHull, ranked_hypotheses


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--seeds', type=int, nargs='+', default=[3540, 3541])
    parser.add_argument('--motions', nargs='+', default=['random', 'pinch'])
    parser.add_argument('--frames', type=int, nargs='+', default=[0, 30])
    args = parser.parse_args()
    model = HandModel.build()
    init = InitConfig()
    unslid = InitConfig(slide_best=0)
    rows = []
    print('| motion | seed | frame | foreground shares | centroid miss (mm) | along the axis '
          '| best unslid (mm) | best slid (mm) | ranking unslid (ms) | ranking slid (ms) |')
    print('|---|---|---|---|---|---|---|---|---|---|')
    for seed in args.seeds:
        for motion in args.motions:
            config = SynthConfig(motion=motion, n_frames=max(args.frames) + 1, seed=seed)
            sequence = SyntheticSequence(config, model)
            pipeline = OfflinePipeline(model, sequence.rig)
            tracker = pipeline.session.tracker
            hull = VisualHull(tracker.cameras)
            for k in args.frames:
                frame = sequence.frame(k)
                observations, _ = pipeline.observe(FrameSet(frame.stamp_ns, frame.images))
                hand_m = model.pose(frame.theta, jacobian=False).vertices_m.mean(axis=0)
                region = hull.locate(observations, init.min_mask_px)
                miss_m = region.centre_m - hand_m

                def best_miss(config: InitConfig) -> tuple[float, float]:
                    """The best-ranked hypothesis's miss (mm) and the ranking's time (ms)."""
                    start = time.perf_counter()
                    theta = ranked_hypotheses(tracker, observations, region, config)[0]
                    spent_ms = 1e3 * (time.perf_counter() - start)
                    centre_m = model.pose(theta, jacobian=False).vertices_m.mean(axis=0)
                    return 1e3 * float(np.linalg.norm(centre_m - hand_m)), spent_ms

                (unslid_mm, unslid_ms), (slid_mm, slid_ms) = best_miss(unslid), best_miss(init)
                row = (1e3 * float(np.linalg.norm(miss_m)),
                       1e3 * abs(float(miss_m @ region.axis)),
                       unslid_mm, slid_mm, unslid_ms, slid_ms)
                rows.append(row)
                shares = ' '.join(f'{np.count_nonzero(o.features.mask) / o.features.mask.size:.2f}'
                                  for o in observations.cameras)
                print(f'| {motion} | {seed} | {k} | {shares} | '
                      + ' | '.join(f'{x:.1f}' for x in row) + ' |', flush=True)
            pipeline.close()
    table = np.array(rows)
    for name, stat in (('median', np.median(table, axis=0)),
                       ('p90', np.percentile(table, 90, axis=0)), ('max', table.max(axis=0))):
        print(f'| {name} | | | | ' + ' | '.join(f'{x:.1f}' for x in stat) + ' |')


if __name__ == '__main__':
    main()
