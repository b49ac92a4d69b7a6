"""Cost of following the hand's scale (``tracking/scale.py``): one frame's measurement and one
model move.

A frame of a synthetic grasp of a hand 1.1x the default size (4 cameras, 320x240, seed 0) is
observed as the tracker observes it; the default model is posed at the true pose. Timed
(median, min, max of repeated calls): the measurement (correspondences of the size terms,
their residuals and Jacobian over pose and scale, the Schur step), and a move (the model built
at a scale not built before, and ``HandTracker.reshape``). Run: ``python bench/bench_scale.py``.
"""
from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from hand_tracker_ros.core.frames import FrameSet
from hand_tracker_ros.energies.registry import SIZE_TERMS
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.shape import HandShape
from hand_tracker_ros.pipeline.offline import OfflinePipeline, PipelineConfig
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence
from hand_tracker_ros.tracking.scale import FrameScale

REPEATS = 20
MOVES = 8


def _times_ms(fn: Callable[[int], object], repeats: int) -> list[float]:
    times = []
    for k in range(repeats):
        t0 = time.perf_counter()
        fn(k)
        times.append(1e3 * (time.perf_counter() - t0))
    return times


def _report(label: str, times: list[float]) -> None:
    print(f'{label:<52s} median {np.median(times):7.2f} ms   min {min(times):7.2f}   '
          f'max {max(times):7.2f}')


def main() -> None:
    """Print the timings."""
    sequence = SyntheticSequence(SynthConfig(motion='grasp', n_frames=10, n_cameras=4, seed=0),
                                 HandModel.build(HandShape(scale=1.1)))
    shot = sequence.frame(6)
    model = HandModel.build()
    pipeline = OfflinePipeline(model, sequence.rig, PipelineConfig())
    try:
        observations = pipeline.observe(FrameSet(shot.stamp_ns, shot.images))[0]
    finally:
        pipeline.close()
    tracker = pipeline.tracker
    tracker.reset(shot.theta)
    posed = model.pose(shot.theta, jacobian=False)
    views = tracker.views(posed)
    terms = [t for t in tracker.terms if t.name in SIZE_TERMS]
    print(f'{len(views)} cameras, {sequence.rig.cameras[0].width}x'
          f'{sequence.rig.cameras[0].height}; the estimate at the true pose: '
          f'{FrameScale(terms, posed, views, observations).estimate()}')
    _report('measurement (FrameScale + estimate)', _times_ms(
        lambda _: FrameScale(terms, posed, views, observations).estimate(), REPEATS))
    # Scales no build has seen, so that HandModel.build's cache does not answer.
    scales = 1.0 + 0.0123 * (1 + np.arange(MOVES))
    _report('move (HandModel.build at a new scale + reshape)', _times_ms(
        lambda k: tracker.reshape(HandModel.build(model.shape.replace(scale=float(scales[k])))),
        MOVES))


if __name__ == '__main__':
    main()
