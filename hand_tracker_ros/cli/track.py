"""`hand-tracker track BAG --out OUT`: bag -> features -> detector -> tracker, no ROS graph.

Deterministic: the same bag and options give the same estimates. Writes a rosbag2 (mcap) with
the live tracker's topics (``/hand/joint_states``, ``/hand/state``, ``/hand/markers``, ``/tf``,
``/hand/robot_description``; :mod:`hand_tracker_ros.ros_io.estimates_bag`); for synthetic bags
(with ground truth) prints the mean 3D joint error.
"""
from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from hand_tracker_ros.geometry.rig import CameraRig
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.shape_file import shape_or_default
from hand_tracker_ros.pipeline.frames import image_count, rig_file
from hand_tracker_ros.pipeline.offline import PipelineConfig
from hand_tracker_ros.pipeline.track_bag import track_bag
from hand_tracker_ros.progress import progress
from hand_tracker_ros.ros_io.estimates_bag import write_estimates
from hand_tracker_ros.status import TrackStatus
from hand_tracker_ros.tracking.scale import ScaleConfig
from hand_tracker_ros.tracking.session import SessionConfig


def add_parser(sub: Any) -> None:
    """Register the verb."""
    parser = sub.add_parser('track', help='track a bag offline', description=__doc__)
    parser.add_argument('bag', help='rosbag2 directory or .mcap file')
    parser.add_argument('--out', required=True, help='output bag directory (must not exist)')
    parser.add_argument('--rig', help='rig YAML (default: rig.yaml beside the bag)')
    parser.add_argument('--init', choices=('auto', 'ground-truth'), default='auto',
                        help='first pose: searched from the images (auto) or the bag\'s ground '
                             'truth (synthetic bags)')
    parser.add_argument('--shape', metavar='SHAPE.yaml',
                        help='hand shape file (hand-tracker calibrate; default: the default '
                             'hand)')
    parser.add_argument('--fixed-scale', action='store_true',
                        help='keep the shape\'s scale (by default the session follows the '
                             'hand\'s scale while tracking: session.scale)')
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Track and write; print a summary."""
    rig = CameraRig.from_yaml(rig_file(args.bag, args.rig))
    model = HandModel.build(shape_or_default(args.shape))
    config = PipelineConfig(session=SessionConfig(scale=ScaleConfig(
        enabled=not args.fixed_scale)))
    estimates = track_bag(args.bag, rig_path=args.rig, config=config,
                          init_from_ground_truth=args.init == 'ground-truth', shape=model.shape)
    frames = write_estimates(progress(estimates, total=image_count(args.bag, rig.names[0]),
                                      desc='track', unit='set'),
                             args.out, rig.world_frame, model)
    tracked = sum(f.result.status == TrackStatus.TRACKING for f in frames)
    ms = 1e3 * np.median([f.result.timings_s['total'] for f in frames]) if frames else 0.0
    print(f'tracked {tracked}/{len(frames)} frame sets ({ms:.0f} ms/frame median); '
          f'wrote {args.out}')
    followed = frames[-1].result.posed.model.shape.scale if frames else model.shape.scale
    if followed != model.shape.scale:
        print(f'hand scale followed while tracking: {model.shape.scale:.3f} -> {followed:.3f} '
              'at the last set (`hand-tracker calibrate` fits the whole shape)')
    errors = [1e3 * np.linalg.norm(f.result.posed.keypoints_m - truth, axis=1).mean()
              for f in frames if (truth := f.truth_keypoints_m) is not None]
    if errors:
        print(f'mean 3D joint error vs ground truth: {np.mean(errors):.2f} mm '
              f'(median {np.median(errors):.2f}, max {np.max(errors):.2f})')
    return 0
