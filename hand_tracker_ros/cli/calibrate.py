"""`hand-tracker calibrate BAG --out SHAPE.yaml`: fit the hand's shape to a recorded motion.

Tracks the bag with the start shape (default: the default hand), picks ``--frames``
well-spread, confidently tracked frames and fits their poses and one hand shape (global scale,
palm length and width, the 15 segment lengths, thickness) jointly to the edges, silhouette
and fingertip detections (:mod:`hand_tracker_ros.calibration.calibrate`). Prints the fitted
values, the image cost before and after, and a warning for every field the sequence does
not constrain. The best motion spreads the fingers, makes a fist and turns the hand (README,
"Hand shape"; ``hand-tracker synth --motion calibration`` renders one).
"""
from __future__ import annotations

import argparse
import time
from typing import Any

from hand_tracker_ros.calibration.calibrate import (
    CalibrationConfig,
    CalibrationResult,
    calibrate_bag,
)
from hand_tracker_ros.model.shape import SHAPE_NAMES
from hand_tracker_ros.model.shape_file import save_shape, shape_or_default


def add_parser(sub: Any) -> None:
    """Register the verb."""
    parser = sub.add_parser('calibrate', help="fit the hand's shape to a bag",
                            description=__doc__)
    parser.add_argument('bag', help='rosbag2 directory or .mcap file')
    parser.add_argument('--out', required=True, metavar='SHAPE.yaml',
                        help='hand shape file to write')
    parser.add_argument('--rig', help='rig YAML (default: rig.yaml beside the bag)')
    parser.add_argument('--frames', type=int, default=CalibrationConfig.frames,
                        help=f'frames fitted jointly (default {CalibrationConfig.frames})')
    parser.add_argument('--shape', metavar='SHAPE.yaml',
                        help='start shape (default: the default hand)')
    parser.set_defaults(run=run)


def report(result: CalibrationResult) -> str:
    """The printed summary: fitted values, residuals before and after, warnings."""
    start, fitted = result.initial_shape.to_vector(), result.shape.to_vector()
    lines = [f'fitted {len(result.stamps_ns)} frames (picked from the {result.tracked_frames} '
             'most confidently tracked)',
             f'{"field":<22} {"start":>9} {"fitted":>9} {"change":>8} {"+-(data)":>9}']
    spreads = [f'{1e3 * s * b:.2f} mm' if name.endswith('_m') else f'{100 * s:.2f} %'
               for name, b, s in zip(SHAPE_NAMES, fitted, result.relative_std)]
    for name, a, b, spread in zip(SHAPE_NAMES, start, fitted, spreads):
        unit = 1e3 if name.endswith('_m') else 1.0
        label = name.removesuffix('_m') + (' (mm)' if unit > 1 else '')
        lines.append(f'{label:<22} {unit * a:9.3f} {unit * b:9.3f} {100 * (b / a - 1):+7.2f}% '
                     f'{spread:>10}')
    lines.append('RMS residual of the frames, start shape -> fitted shape:')
    for name, (rms, rows) in result.initial_rms.items():
        rms_unit, factor = ('mm', 1e3) if name == 'silhouette' else ('px', 1.0)
        rms_after, rows_after = result.final_rms[name]
        lines.append(f'  {name:<11} {factor * rms:7.3f} {rms_unit} ({rows} rows) -> '
                     f'{factor * rms_after:7.3f} {rms_unit} ({rows_after} rows)')
    lines += [f'warning: the sequence does not constrain {name} (+-{spread} from the data '
              'alone); its value stays near the start shape'
              for name, spread in zip(SHAPE_NAMES, spreads) if name in result.unconstrained]
    lines.append('(lengths before the scale; +-(data): standard deviation from the data alone)')
    return '\n'.join(lines)


def run(args: argparse.Namespace) -> int:
    """Calibrate, print the report, write the shape file."""
    start = time.monotonic()
    config = CalibrationConfig(frames=args.frames)
    result = calibrate_bag(args.bag, rig_path=args.rig, config=config,
                           initial=shape_or_default(args.shape))
    print(report(result))
    save_shape(result.shape, args.out,
               comment=f'hand-tracker calibrate {args.bag} ({len(result.stamps_ns)} frames)')
    print(f'wrote {args.out} ({time.monotonic() - start:.1f} s)')
    return 0
