"""`hand-tracker warmup`: compile every JIT kernel of the pipeline into numba's on-disk cache
(:mod:`hand_tracker_ros.pipeline.warmup`); ``tools/setup.sh`` runs it once per build."""
from __future__ import annotations

import argparse
from typing import Any

from hand_tracker_ros.pipeline.warmup import warm_up


def add_parser(sub: Any) -> None:
    """Register the verb."""
    parser = sub.add_parser('warmup', help='compile the JIT kernels into the on-disk cache',
                            description=__doc__)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:  # noqa: ARG001 - the verb takes no options
    """Track three synthetic frames; print the time."""
    print(f'JIT kernels compiled or loaded from the cache in {warm_up():.1f} s')
    return 0
