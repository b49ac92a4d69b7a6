"""`hand-tracker train-detector`: train the fingertip network on synthetic renders.

Needs PyTorch and ONNX (requirements/train.txt), which the default install leaves out: without
them the command prints the exact pip command, or runs it with ``--install``
(``HT_TRAIN=1 bash tools/setup.sh`` installs them too). The same seed and options give the same
model file, byte for byte, on the same machine. The shipped model
(hand_tracker_ros/vision/models/fingertip_cnn.onnx) was trained in two steps:
``train-detector --seed 0 --out base.onnx`` (the defaults, 2 threads), then
``train-detector --seed 0 --init base.onnx --epochs 15 --lr 1e-3 --threads 1`` (the
fine-tune of ``vision/detector/training.py``'s log, fourteenth session).
"""
from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import shlex
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from hand_tracker_ros.ament import share_file
from hand_tracker_ros.config import validate
from hand_tracker_ros.errors import HandTrackerError
from hand_tracker_ros.vision.detector.model import default_model_path
from hand_tracker_ros.vision.detector.training import TrainingConfig, train

# Importable names of the packages in requirements/train.txt.
TRAINING_MODULES = ('torch', 'onnx')


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
    parser.add_argument('--threads', type=int, default=defaults.threads,
                        help=f'PyTorch threads (default {defaults.threads}; the model bytes '
                             'may depend on it)')
    parser.add_argument('--init', default='',
                        help='start from this .onnx model (fine-tuning; default: random '
                             'initialisation)')
    parser.add_argument('--lr', type=float, default=defaults.learning_rate,
                        help=f'peak learning rate (default {defaults.learning_rate})')
    parser.add_argument('--install', action='store_true',
                        help='first install the training requirements (PyTorch, ONNX) with pip '
                             'if they are missing')
    parser.set_defaults(run=run)


def ensure_training_requirements(install: bool) -> None:
    """Raise a :class:`HandTrackerError` with the exact pip command if PyTorch or ONNX is
    missing, or (``install``) run that command."""
    missing = [name for name in TRAINING_MODULES if importlib.util.find_spec(name) is None]
    if not missing:
        return
    command = [sys.executable, '-m', 'pip', 'install', '-r',
               str(share_file('requirements/train.txt'))]
    if not install:
        msg = (f'train-detector needs {" and ".join(missing)} (the training requirements, not '
               f'in the default install). Install them with\n  {shlex.join(command)}\n'
               'or run again with --install (or set HT_TRAIN=1 for tools/setup.sh)')
        raise HandTrackerError(msg)
    print(f'installing the training requirements: {shlex.join(command)}', flush=True)
    if subprocess.run(command, check=False).returncode != 0:
        msg = f'installing the training requirements failed: {shlex.join(command)}'
        raise HandTrackerError(msg)
    importlib.invalidate_caches()


def run(args: argparse.Namespace) -> int:
    """Train and write the model; print where it went."""
    ensure_training_requirements(args.install)
    config = dataclasses.replace(TrainingConfig(), n_views=args.views, epochs=args.epochs,
                                 threads=args.threads, init_model=args.init,
                                 learning_rate=args.lr)
    validate(config)
    out = Path(args.out) if args.out else default_model_path()
    start = time.monotonic()
    model = train(args.seed, config)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_bytes(model)
    print(f'wrote {out} ({len(model)} bytes, {args.views} views, {args.epochs} epochs, '
          f'{time.monotonic() - start:.0f} s)')
    return 0
