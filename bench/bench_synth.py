"""Synthetic-sequence throughput: frames (4 camera views each) rendered per second.

Usage: python bench/bench_synth.py
"""
from __future__ import annotations

import statistics
import time

from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence


def main() -> None:
    model = HandModel.build()
    for width, height in ((320, 240), (640, 480)):
        seq = SyntheticSequence(SynthConfig(motion='random', n_frames=40, width=width,
                                            height=height), model)
        seq.frame(0)  # warm-up: numba kernels, backgrounds
        times = []
        for k in range(1, 40):
            start = time.perf_counter()
            seq.frame(k)
            times.append(time.perf_counter() - start)
        med = statistics.median(times)
        print(f'synth {width}x{height}, 4 cameras: median {1e3 * med:.1f} ms/frame '
              f'({1 / med:.1f} frames/s), min {1e3 * min(times):.1f}, max {1e3 * max(times):.1f}')


if __name__ == '__main__':
    main()
