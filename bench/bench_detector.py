"""Fingertip detector on held-out synthetic views: precision, recall, localisation, time.

Held-out views come from ``labelled_views(seed=HELD_OUT_SEED)``: poses, rigs, backgrounds,
lighting and noise drawn from a seed the shipped model (``train-detector --seed 0``) never
saw. A detection is a true positive within 8 px of an unmatched visible tip; detections near
only invisible tips count as neither (see ``vision/detector/evaluation.py``).

Usage: python bench/bench_detector.py [--views N] [--model PATH] [--sweep]
(``--sweep`` also prints precision/recall at other ``min_score`` values.)
"""
from __future__ import annotations

import argparse
import dataclasses
import statistics
import time

from hand_tracker_ros.vision.detector.data import labelled_views
from hand_tracker_ros.vision.detector.detector import DetectorConfig, FingertipDetector
from hand_tracker_ros.vision.detector.evaluation import DetectionTally

HELD_OUT_SEED = 20_261_122


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument('--views', type=int, default=300)
    parser.add_argument('--model', default=None)
    parser.add_argument('--sweep', action='store_true')
    args = parser.parse_args()
    detector = FingertipDetector.load(args.model, DetectorConfig())
    views = list(labelled_views(args.views, HELD_OUT_SEED))
    detector.detect(views[0].image)  # warm-up: ONNX Runtime allocates its buffers
    tally, times = DetectionTally(), []
    for view in views:
        start = time.perf_counter()
        detections = detector.detect(view.image)
        times.append(time.perf_counter() - start)
        tally.add(detections, view.tips_uv, view.tips_visible, radius_px=8.0)
    p50, p90 = tally.error_percentiles((50.0, 90.0))
    print(f'held-out views: {len(views)} (320x240), visible tips: {tally.visible_tips}')
    print(f'precision {tally.precision:.3f} (TP {tally.true_positives}, '
          f'FP {tally.false_positives}, near invisible tips {tally.ignored})')
    print(f'recall    {tally.recall:.3f}')
    print(f'localisation error of TPs: median {p50:.2f} px, 90th percentile {p90:.2f} px')
    ms = [1e3 * t for t in times]
    print(f'detector: median {statistics.median(ms):.2f} ms/frame, min {min(ms):.2f}, '
          f'max {max(ms):.2f}')
    if args.sweep:
        for min_score in (0.2, 0.3, 0.4, 0.5, 0.6, 0.7):
            config = dataclasses.replace(DetectorConfig(), min_score=min_score)
            swept = FingertipDetector(detector.model, config)
            tally = DetectionTally()
            for view in views:
                tally.add(swept.detect(view.image), view.tips_uv, view.tips_visible)
            print(f'min_score {min_score:.1f}: precision {tally.precision:.3f}, '
                  f'recall {tally.recall:.3f}')


if __name__ == '__main__':
    main()
