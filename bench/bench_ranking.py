"""The start hypotheses' ranking: rendered silhouette IoU against the coarse splat IoU.

Usage: python bench/bench_ranking.py [--seeds 21 22] [--frames 0 15 29]

For each seed (random motion; 4 x 320x240 for the first seed, 4 x 640x480 for the second,
and alternating after) and frame, the 48 hypotheses of ``tracking.initialize.hypotheses`` at
the true hand centre are scored both ways; one row per frame: the wall time of each
(posing included), Spearman's rank correlation of the two scores, and the splat ranks of the
rendered IoU's top 8.
"""
from __future__ import annotations

import argparse
import time

import numpy as np
import scipy.stats

from hand_tracker_ros.core.frames import FrameSet
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.pipeline.offline import OfflinePipeline
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence
from hand_tracker_ros.tracking.evidence import CoarseMasks, silhouette_iou
from hand_tracker_ros.tracking.initialize import InitConfig, hypotheses


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--seeds', type=int, nargs='+', default=[21, 22])
    parser.add_argument('--frames', type=int, nargs='+', default=[0, 15, 29])
    args = parser.parse_args()
    model = HandModel.build()
    print('| rig | seed | frame | rendered (ms) | splat (ms) | Spearman | splat ranks of the '
          'rendered top 8 |\n|---|---|---|---|---|---|---|')
    for k, seed in enumerate(args.seeds):
        width, height = (320, 240) if k % 2 == 0 else (640, 480)
        sequence = SyntheticSequence(SynthConfig(motion='random', n_frames=max(args.frames) + 1,
                                                 seed=seed, width=width, height=height), model)
        pipeline = OfflinePipeline(model, sequence.rig)
        tracker = pipeline.session.tracker
        for index in args.frames:
            frame = sequence.frame(index)
            observations, _ = pipeline.observe(FrameSet(frame.stamp_ns, frame.images))
            centre = model.pose(frame.theta, jacobian=False).vertices_m.mean(axis=0)
            starts = hypotheses(model, centre, InitConfig())
            t0 = time.perf_counter()
            rendered = np.array([silhouette_iou(tracker.views(model.pose(t, jacobian=False)),
                                                observations) for t in starts])
            t1 = time.perf_counter()
            masks = CoarseMasks(observations, tracker.cameras)
            splat = np.array([masks.iou(model.pose(t, jacobian=False).vertices_m)
                              for t in starts])
            t2 = time.perf_counter()
            rank_r = np.argsort(np.argsort(-rendered))
            rank_s = np.argsort(np.argsort(-splat))
            print(f'| 4 x {width}x{height} | {seed} | {index} | {1e3 * (t1 - t0):.0f} '
                  f'| {1e3 * (t2 - t1):.0f} | {scipy.stats.spearmanr(rendered, splat)[0]:.2f} '
                  f'| {sorted(int(r) for r in rank_s[rank_r < 8])} |', flush=True)
        pipeline.close()


if __name__ == '__main__':
    main()
