"""`hand-tracker replay-eval BAG`: the live graph on a bag, scored and compared with offline.

Plays the bag through the multi-process graph (player -> features, salient_points -> tracker
-> recorder), scores the recorded estimates against the bag's ground truth, then tracks the
same bag with the offline path (``hand-tracker track``) and prints both and their difference.
"""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from hand_tracker_ros.evaluation.replay import replay
from hand_tracker_ros.pipeline.offline import PipelineConfig
from hand_tracker_ros.pipeline.track_bag import track_bag


def add_parser(sub: Any) -> None:
    """Register the verb."""
    parser = sub.add_parser('replay-eval', help='score the live graph on a bag',
                            description=__doc__)
    parser.add_argument('bag', help='synthetic rosbag2 (with ground truth)')
    parser.add_argument('--out', default='out/replay', help='output directory')
    parser.add_argument('--rate', type=float, default=0.1,
                        help='playback rate (default 0.1: slow enough that no set is dropped '
                             'on a 2-core machine; 1.0 is real time)')
    parser.add_argument('--rig', help='rig YAML (default: rig.yaml beside the bag)')
    parser.add_argument('--no-offline', action='store_true', help='skip the offline comparison')
    parser.set_defaults(run=run)


def offline_mean_error_mm(bag: str, rig: str | None) -> float:
    """Mean 3D joint error of the offline path, frames after the (ground-truth) first one."""
    frames = list(track_bag(bag, rig_path=rig, config=PipelineConfig(),
                            init_from_ground_truth=True))[1:]
    return float(np.mean([1e3 * np.linalg.norm(f.result.posed.keypoints_m
                                               - f.truth_keypoints_m, axis=1).mean()
                          for f in frames if f.truth_keypoints_m is not None]))


def run(args: argparse.Namespace) -> int:
    """Replay, score, compare."""
    outcome = replay(args.bag, Path(args.out), rate=args.rate, rig_path=args.rig)
    print(f'recorded {outcome.recorded_bag}: {outcome.joint_states} JointState for '
          f'{outcome.input_sets} input frame sets '
          f'({100.0 * outcome.joint_states / max(outcome.input_sets, 1):.0f} %)')
    if outcome.scores is None:
        print('no estimate matched a ground-truth stamp')
        return 1
    s = outcome.scores
    print(f'live graph: mean 3D joint error {s.joint_mean_mm:.2f} mm (median '
          f'{s.joint_median_mm:.2f}, max {s.joint_max_mm:.2f}), fingertips '
          f'{s.fingertip_mean_mm:.2f} mm, {s.failures} failures, '
          f'{s.ms_per_frame:.0f} ms/frame in the tracker')
    if not args.no_offline:
        offline = offline_mean_error_mm(args.bag, args.rig)
        print(f'offline path: mean 3D joint error {offline:.2f} mm; '
              f'difference {s.joint_mean_mm - offline:+.2f} mm')
    return 0
