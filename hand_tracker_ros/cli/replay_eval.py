"""`hand-tracker replay-eval BAG`: the live graph on a bag, scored and compared with offline.

Plays the bag through the graph (player -> tracker, composed with features and
salient_points or with them as processes (``--mode``) -> recorder) at ``--rate`` (default
real time), both paths started at the ground-truth first pose. It prints the share of sets
estimated, estimates per second, the latency and the error against the bag's ground truth,
then tracks the same bag offline (``hand-tracker track``) at the live tracker's working
resolution (the nodes' ``working_width_px``, the same in both modes), so that the difference
is live against offline only, and prints that error and the difference.
"""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from hand_tracker_ros.evaluation.replay import live_summary, replay
from hand_tracker_ros.launcher import GRAPH_MODES
from hand_tracker_ros.node_config import TrackerNodeConfig
from hand_tracker_ros.pipeline.offline import PipelineConfig
from hand_tracker_ros.pipeline.track_bag import track_bag


def add_parser(sub: Any) -> None:
    """Register the verb."""
    parser = sub.add_parser('replay-eval', help='score the live graph on a bag',
                            description=__doc__)
    parser.add_argument('bag', help='synthetic rosbag2 (with ground truth)')
    parser.add_argument('--out', default='out/replay', help='output directory')
    parser.add_argument('--rate', type=float, default=1.0,
                        help='playback rate (default 1.0: real time)')
    parser.add_argument('--mode', choices=GRAPH_MODES, default='composed',
                        help='composed (default): one tracker process hosting features and '
                             'salient_points; distributed: three processes')
    parser.add_argument('--rig', help='rig YAML (default: rig.yaml beside the bag)')
    parser.add_argument('--no-offline', action='store_true', help='skip the offline comparison')
    parser.set_defaults(run=run)


def offline_mean_error_mm(bag: str, rig: str | None, working_width_px: int) -> float:
    """Mean 3D joint error of the offline path, frames after the (ground-truth) first one."""
    config = PipelineConfig(working_width_px=working_width_px)
    frames = list(track_bag(bag, rig_path=rig, config=config,
                            init_from_ground_truth=True))[1:]
    return float(np.mean([1e3 * np.linalg.norm(f.result.posed.keypoints_m
                                               - f.truth_keypoints_m, axis=1).mean()
                          for f in frames if f.truth_keypoints_m is not None]))


def run(args: argparse.Namespace) -> int:
    """Replay, score, compare."""
    outcome = replay(args.bag, Path(args.out), rate=args.rate, rig_path=args.rig,
                     mode=args.mode)
    print(live_summary(outcome))
    if outcome.scores is None:
        print('no estimate matched a ground-truth stamp')
        return 1
    s = outcome.scores
    print(f'live graph: mean 3D joint error {s.joint_mean_mm:.2f} mm (median '
          f'{s.joint_median_mm:.2f}, max {s.joint_max_mm:.2f}), fingertips '
          f'{s.fingertip_mean_mm:.2f} mm, {s.failures} failures, '
          f'{s.ms_per_frame:.0f} ms/frame in the tracker')
    if not args.no_offline:
        width = TrackerNodeConfig().working_width_px
        offline = offline_mean_error_mm(args.bag, args.rig, width)
        at = f'images wider than {width} px scaled to it' if width else "the images' size"
        print(f'offline path ({at}, as live): mean 3D joint error {offline:.2f} mm; '
              f'difference {s.joint_mean_mm - offline:+.2f} mm')
    return 0
