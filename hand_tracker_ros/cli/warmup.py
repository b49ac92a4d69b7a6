"""`hand-tracker warmup`: compile every JIT kernel of the pipeline into numba's on-disk cache.

The numba kernels (rendering, projection, skinning, correspondences, collisions) are compiled
with ``cache=True``: the first process that calls one compiles it (seconds in all) and writes
the machine code next to the module, where every later process loads it. ``tools/setup.sh``
runs this verb once per build, so that no node and no test compiles while frames arrive.
It tracks a few frames of a small synthetic sequence with the automatic start (the search,
recovery and every energy term run) and prints how long that took.
"""
from __future__ import annotations

import argparse
import time
from typing import Any

from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.pipeline.frames import FrameSet
from hand_tracker_ros.pipeline.offline import OfflinePipeline, PipelineConfig
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence


def add_parser(sub: Any) -> None:
    """Register the verb."""
    parser = sub.add_parser('warmup', help='compile the JIT kernels into the on-disk cache',
                            description=__doc__)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:  # noqa: ARG001 - the verb takes no options
    """Track three synthetic frames; print the time."""
    start = time.monotonic()
    model = HandModel.build()
    sequence = SyntheticSequence(SynthConfig(motion='random', n_frames=3, n_cameras=2,
                                             seed=7), model)
    pipeline = OfflinePipeline(model, sequence.rig, PipelineConfig())
    try:
        for _ in pipeline.run(FrameSet(f.stamp_ns, f.images) for f in sequence):
            pass
    finally:
        pipeline.close()
    print(f'JIT kernels compiled or loaded from the cache in {time.monotonic() - start:.1f} s')
    return 0
