"""The README's hand-shape table: calibrate synthetic hands of other sizes, then track them.

For every (shape, motion, seed) this renders a 90-frame 4-camera bag of that hand
(``hand-tracker synth --shape``), runs ``hand-tracker calibrate`` (timed) and tracks the bag
with the true, the calibrated and the default shape (``--fixed-scale``), and with the default
shape whose scale the session follows (the default of ``track``), and prints one markdown row:
fitted scale, segment, palm and thickness errors, the four mean 3D joint errors, the true and
calibrated shape's errors once more when tracking starts from the true first pose (``track
--init ground-truth``: without the automatic start's choice of basin, the difference is the
shape's), the calibrate time and the fields ``calibrate`` warned the sequence does not
constrain.

Usage: python bench/calibrate_shapes.py OUT_DIR [--cases small:grasp:51 ...]
(shapes: small = 0.9x, large = 1.1x, longfingers = every segment 8 % longer, default).
Each case takes a few minutes on 2 cores.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import logging
import re
import time
from pathlib import Path

import numpy as np

from hand_tracker_ros.cli.main import main as cli
from hand_tracker_ros.model.shape import HandShape
from hand_tracker_ros.model.shape_file import load_shape, save_shape

_CASES = ('small:grasp:51', 'small:random:52', 'large:grasp:51', 'large:random:52',
          'longfingers:grasp:51', 'longfingers:random:52', 'large:calibration:53',
          'longfingers:calibration:53', 'default:grasp:51')


def _shape(name: str) -> HandShape:
    d = HandShape()
    longer = {f: tuple(1.08 * v for v in getattr(d, f))
              for f in ('thumb_m', 'index_m', 'middle_m', 'ring_m', 'pinky_m')}
    return {'small': HandShape(scale=0.9), 'large': HandShape(scale=1.1),
            'longfingers': d.replace(**longer), 'default': d}[name]


def _quiet(*args: str) -> str:
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert cli(list(args)) == 0, args
    return out.getvalue()


def _track_error(bag: Path, out: Path, *shape: str) -> float:
    text = _quiet('track', str(bag), '--out', str(out), *shape)
    return float(re.search(r'ground truth: ([0-9.]+) mm', text).group(1))


def run_case(root: Path, case: str) -> str:
    """Synthesize, calibrate and track one case; its markdown row."""
    name, motion, seed = case.split(':')
    seq = root / case.replace(':', '-')
    save_shape(_shape(name), root / f'{name}.yaml')
    _quiet('synth', '--out', str(seq), '--motion', motion, '--frames', '90', '--seed', seed,
           '--shape', str(root / f'{name}.yaml'))
    start = time.perf_counter()
    printed = _quiet('calibrate', str(seq / 'bag'), '--out', str(seq / 'calibrated.yaml'))
    seconds = time.perf_counter() - start
    flagged = re.findall(r'^warning: the sequence does not constrain (\S+)', printed, re.M)
    true, fit = load_shape(seq / 'shape.yaml'), load_shape(seq / 'calibrated.yaml')
    seg = 1e3 * np.abs(fit.finger_lengths_m() - true.finger_lengths_m())
    palm = [1e3 * (fit.scale * getattr(fit, f) - true.scale * getattr(true, f))
            for f in ('palm_length_m', 'palm_width_m')]
    thick = fit.scale * fit.radius_scale / (true.scale * true.radius_scale) - 1.0
    errors = [_track_error(seq / 'bag', seq / 'est-default', '--fixed-scale'),
              _track_error(seq / 'bag', seq / 'est-followed'),
              _track_error(seq / 'bag', seq / 'est-true', '--shape', str(seq / 'shape.yaml'),
                           '--fixed-scale'),
              _track_error(seq / 'bag', seq / 'est-cal', '--shape',
                           str(seq / 'calibrated.yaml'), '--fixed-scale')]
    from_truth = [_track_error(seq / 'bag', seq / f'est-{which}-from-truth', '--shape',
                               str(seq / f'{which}.yaml'), '--init', 'ground-truth',
                               '--fixed-scale')
                  for which in ('shape', 'calibrated')]
    scale_error = 100 * (fit.scale / true.scale - 1)
    return (f'| {name} ({motion}, {seed}) | {fit.scale:.3f} ({scale_error:+.1f} %) '
            f'| {seg.max():.1f} / {seg.mean():.1f} | {palm[0]:+.1f} / {palm[1]:+.1f} '
            f'| {100 * thick:+.1f} % | {" / ".join(f"{e:.2f}" for e in errors)} '
            f'| {errors[3] - errors[2]:+.2f} | {from_truth[0]:.2f} / {from_truth[1]:.2f} '
            f'({from_truth[1] - from_truth[0]:+.2f}) | {seconds:.0f} s '
            f'| {", ".join(flagged) or "none"} |')


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('out', type=Path, help='directory for the bags (must not hold them)')
    parser.add_argument('--cases', nargs='+', default=_CASES, help='shape:motion:seed ...')
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING)   # before the CLI's INFO default
    args.out.mkdir(parents=True, exist_ok=True)
    print('| bag (motion, seed) | fitted scale (error) | segment error max / mean (mm) | palm '
          'length / width error (mm) | thickness error | mean 3D joint error: default / '
          'default, scale followed / true / calibrated shape (mm) | calibrated - true (mm) | '
          'from the true first pose: true / '
          'calibrated (difference) (mm) | calibrate | fields flagged as not constrained |')
    print('|---|---|---|---|---|---|---|---|---|---|')
    for case in args.cases:
        print(run_case(args.out, case), flush=True)


if __name__ == '__main__':
    main()
