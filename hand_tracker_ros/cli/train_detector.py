"""`hand-tracker train-detector`: train the fingertip Hough forest on synthetic renders.

The same seed and options give the same model file, byte for byte. The shipped model
(hand_tracker_ros/vision/models/fingertip_forest.npz) is ``train-detector --seed 0``.
"""
from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path
from typing import Any

from hand_tracker_ros.config import validate
from hand_tracker_ros.vision.detector.model import default_model_path
from hand_tracker_ros.vision.detector.training import TrainingConfig, train


def add_parser(sub: Any) -> None:
    """Register the verb."""
    defaults = TrainingConfig()
    parser = sub.add_parser('train-detector', help='train the fingertip detector',
                            description=__doc__)
    parser.add_argument('--seed', type=int, required=True, help='seed of data and forest')
    parser.add_argument('--out', default=None,
                        help=f'output .npz (default: the shipped model, {default_model_path()})')
    parser.add_argument('--views', type=int, default=defaults.n_views,
                        help=f'rendered training views (default {defaults.n_views})')
    parser.add_argument('--trees', type=int, default=defaults.n_trees,
                        help=f'trees of the forest (default {defaults.n_trees})')
    parser.add_argument('--verifier-views', type=int, default=defaults.verifier_views,
                        help=f'rendered views for the peak verifier (default '
                             f'{defaults.verifier_views})')
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Train and write the model; print where it went."""
    config = dataclasses.replace(TrainingConfig(), n_views=args.views, n_trees=args.trees,
                                 verifier_views=args.verifier_views)
    validate(config)
    out = Path(args.out) if args.out else default_model_path()
    start = time.monotonic()
    model = train(args.seed, config)
    out.parent.mkdir(parents=True, exist_ok=True)
    model.save(out)
    print(f'wrote {out} ({model.forest.left.size} nodes, {len(model.forest.roots)} trees, '
          f'{args.views} + {args.verifier_views} views, {time.monotonic() - start:.0f} s)')
    return 0
