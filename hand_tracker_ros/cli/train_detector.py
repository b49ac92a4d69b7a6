"""`hand-tracker train-detector`: train the fingertip network on synthetic renders.

Needs PyTorch (requirements/train.txt). The same seed and options give the same model file,
byte for byte, on the same machine. The shipped model
(hand_tracker_ros/vision/models/fingertip_cnn.onnx) is ``train-detector --seed 0``.
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
    parser.add_argument('--seed', type=int, required=True,
                        help='seed of data, initialisation and batches')
    parser.add_argument('--out', default=None,
                        help=f'output .onnx (default: the shipped model, {default_model_path()})')
    parser.add_argument('--views', type=int, default=defaults.n_views,
                        help=f'rendered training views (default {defaults.n_views})')
    parser.add_argument('--epochs', type=int, default=defaults.epochs,
                        help=f'passes over the views (default {defaults.epochs})')
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Train and write the model; print where it went."""
    config = dataclasses.replace(TrainingConfig(), n_views=args.views, epochs=args.epochs)
    validate(config)
    out = Path(args.out) if args.out else default_model_path()
    start = time.monotonic()
    model = train(args.seed, config)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_bytes(model)
    print(f'wrote {out} ({len(model)} bytes, {args.views} views, {args.epochs} epochs, '
          f'{time.monotonic() - start:.0f} s)')
    return 0
