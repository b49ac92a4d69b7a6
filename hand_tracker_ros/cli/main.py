"""`hand-tracker`: the command-line entry of the project.

Each verb lives in its own module under ``hand_tracker_ros.cli`` with ``add_parser`` and
``run``; this module only wires them into one ``argparse`` tree.
"""
from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence

from hand_tracker_ros.cli import (
    bag_info,
    calibrate,
    demo,
    evaluate,
    launch,
    params,
    play,
    record,
    replay_eval,
    robustness,
    synth,
    topics,
    track,
    train_detector,
    urdf,
    warmup,
)
from hand_tracker_ros.errors import HandTrackerError

VERBS = (bag_info, calibrate, demo, evaluate, launch, params, play, record, replay_eval,
         robustness, synth, topics, track, train_detector, urdf, warmup)


def build_parser() -> argparse.ArgumentParser:
    """The full argument parser (one sub-parser per verb)."""
    parser = argparse.ArgumentParser(
        prog='hand-tracker',
        description='Markerless multi-camera hand motion capture for ROS 2.')
    parser.add_argument('-v', '--verbose', action='store_true', help='debug logging')
    sub = parser.add_subparsers(dest='verb', required=True, metavar='VERB')
    for verb in VERBS:
        verb.add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Parse ``argv`` and run the chosen verb; errors of ours become one clear line."""
    args = build_parser().parse_args(argv)
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.INFO,
                        format='%(levelname)s %(name)s: %(message)s')
    try:
        return int(args.run(args))
    except HandTrackerError as err:
        print(f'hand-tracker {args.verb}: error: {err}', file=sys.stderr)
        return 2


if __name__ == '__main__':
    raise SystemExit(main())
