"""Load (or compile) every JIT kernel of the pipeline before frames arrive.

The numba kernels (rendering, projection, skinning, correspondences, collisions, the search)
are compiled with ``cache=True``: the first process that calls one compiles it (about a
minute in all on 2 cores) and writes the machine code next to the module; every later
process loads it on its first call (about 2 s in all). :func:`warm_up` makes those first
calls on a small synthetic sequence: ``tools/setup.sh`` runs it once per build (through
``hand-tracker warmup``) and the tracker runs it before it subscribes to its inputs, so the
first set a graph delivers is tracked at full speed.
"""
from __future__ import annotations

import time

from hand_tracker_ros.core.frames import FrameSet
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.pipeline.offline import OfflinePipeline, PipelineConfig
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence


def warm_up(model: HandModel | None = None) -> float:
    """Track three frames of a 2-camera synthetic sequence from the automatic start (the
    search, recovery and every energy term run); return the wall time, s."""
    start = time.monotonic()
    model = HandModel.build() if model is None else model
    sequence = SyntheticSequence(SynthConfig(motion='random', n_frames=3, n_cameras=2,
                                             seed=7), model)
    pipeline = OfflinePipeline(model, sequence.rig, PipelineConfig())
    try:
        for _ in pipeline.run(FrameSet(f.stamp_ns, f.images) for f in sequence):
            pass
    finally:
        pipeline.close()
    return time.monotonic() - start
