"""Fingertip detector on held-out synthetic views: precision, recall, localisation, time.

Held-out views come from ``labelled_views(seed=HELD_OUT_SEED)``: poses, rigs, backgrounds,
lighting and noise drawn from a seed the shipped model (trained on seed 0, both steps of
``cli/train_detector.py``'s recipe) never saw. A detection is a true positive within 8 px of
an unmatched visible tip; detections near only invisible tips count as neither (see
``vision/detector/evaluation.py``).

Usage: python bench/bench_detector.py [--views N] [--model PATH] [--sweep] [--seed S]
    [--upscale F] [--max-hand-px PX] [--edge-crops]
(``--sweep`` also prints precision/recall at other ``min_score`` values; ``--upscale F``
enlarges each view F times (bilinear), its tips and the 8 px radius with it: hands F times
the synthetic size, as close to the camera or at a higher resolution; ``--seed 1`` gives the
validation views the detector settings were chosen on; ``--edge-crops`` cuts each view so
that one visible tip lies 2-8 px inside the image edge its finger points to, and also prints
the recall of those tips: a hand at the end of the image.)
"""
from __future__ import annotations

import argparse
import dataclasses
import statistics
import time

import cv2
import numpy as np

from hand_tracker_ros.vision.detector.data import LabelledView, labelled_views
from hand_tracker_ros.vision.detector.detector import DetectorConfig, FingertipDetector
from hand_tracker_ros.vision.detector.evaluation import DetectionTally

HELD_OUT_SEED = 20_261_122


def upscaled(view: LabelledView, factor: float) -> LabelledView:
    """``view`` enlarged ``factor`` times (bilinear), tips with it (pixel centres)."""
    if factor == 1.0:
        return view
    image = cv2.resize(view.image, None, fx=factor, fy=factor, interpolation=cv2.INTER_LINEAR)
    mask = cv2.resize(view.hand_mask.astype(np.uint8), image.shape[1::-1],
                      interpolation=cv2.INTER_NEAREST) > 0
    return LabelledView(image, mask, (view.tips_uv + 0.5) * factor - 0.5, view.tips_visible)


def edge_cropped(view: LabelledView, rng: np.random.Generator
                 ) -> tuple[LabelledView, int] | None:
    """``view`` cut so that a visible tip drawn from ``rng`` lies 2-8 px inside the image
    edge its finger points to (the side it is farthest from the hand's centroid towards),
    and that tip's index; None when no tip is visible, the view ends before the cut or the
    cut leaves under 64 px. Pixel centres are integers: the edge after pixel ``n - 1`` is
    at ``n - 0.5``, and a tip shows when it rounds to a pixel inside (as in
    ``render/fingertips.py``)."""
    visible = np.flatnonzero(view.tips_visible)
    if visible.size == 0:
        return None
    k = int(rng.choice(visible))
    tip = view.tips_uv[k]
    rows, cols = np.nonzero(view.hand_mask)
    du, dv = tip - (cols.mean(), rows.mean())
    # The edge lands gap - 1 to gap px beyond the tip: 2-8 px.
    gap = rng.uniform(3.0, 8.0)
    height, width = view.image.shape[:2]
    box = [0, 0, width, height]                         # u0, v0, u1, v1
    axis = 0 if abs(du) > abs(dv) else 1
    if (du, dv)[axis] > 0:
        box[2 + axis] = int(np.floor(tip[axis] + gap + 0.5))
    else:
        box[axis] = int(np.ceil(tip[axis] - gap + 0.5))
    u0, v0, u1, v1 = box
    if u0 < 0 or v0 < 0 or u1 > width or v1 > height or u1 - u0 < 64 or v1 - v0 < 64:
        return None
    uv = view.tips_uv - (u0, v0)
    with np.errstate(invalid='ignore'):
        inside = np.all((np.rint(uv) >= 0.0) & (np.rint(uv) < (u1 - u0, v1 - v0)), axis=1)
    return LabelledView(np.ascontiguousarray(view.image[v0:v1, u0:u1]),
                        view.hand_mask[v0:v1, u0:u1], uv, view.tips_visible & inside), k


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument('--views', type=int, default=300)
    parser.add_argument('--model', default=None)
    parser.add_argument('--sweep', action='store_true')
    parser.add_argument('--seed', type=int, default=HELD_OUT_SEED)
    parser.add_argument('--upscale', type=float, default=1.0)
    parser.add_argument('--max-hand-px', type=float, default=DetectorConfig().max_hand_px)
    parser.add_argument('--edge-crops', action='store_true')
    args = parser.parse_args()
    base = dataclasses.replace(DetectorConfig(), max_hand_px=args.max_hand_px)
    detector = FingertipDetector.load(args.model, base)
    views = [upscaled(view, args.upscale) for view in labelled_views(args.views, args.seed)]
    edge_tips: list[int] = []      # with --edge-crops: the index of each view's tip at the edge
    if args.edge_crops:
        rng = np.random.default_rng(args.seed)
        kept = [cut for cut in (edge_cropped(view, rng) for view in views) if cut is not None]
        views, edge_tips = [view for view, _ in kept], [k for _, k in kept]
    radius_px = 8.0 * args.upscale
    detector.detect(views[0].image)  # warm-up: ONNX Runtime allocates its buffers
    tally, edge_found, times = DetectionTally(), [], []
    for i, view in enumerate(views):
        start = time.perf_counter()
        detections = detector.detect(view.image)
        times.append(time.perf_counter() - start)
        found = tally.add(detections, view.tips_uv, view.tips_visible, radius_px=radius_px)
        if edge_tips:
            edge_found.append(bool(found[edge_tips[i]]))
    p50, p90 = tally.error_percentiles((50.0, 90.0))
    height, width = views[0].image.shape[:2]
    size = 'cut at a tip' if edge_tips else f'{width}x{height}'
    print(f'views of seed {args.seed}: {len(views)} ({size}), visible tips: '
          f'{tally.visible_tips}')
    print(f'precision {tally.precision:.3f} (TP {tally.true_positives}, '
          f'FP {tally.false_positives}, near invisible tips {tally.ignored})')
    print(f'recall    {tally.recall:.3f}')
    if edge_tips:
        print(f'recall of the tips at the image edge {np.mean(edge_found):.3f} '
              f'({len(edge_found)} tips)')
    print(f'localisation error of TPs: median {p50:.2f} px, 90th percentile {p90:.2f} px')
    ms = [1e3 * t for t in times]
    print(f'detector: median {statistics.median(ms):.2f} ms/frame, min {min(ms):.2f}, '
          f'max {max(ms):.2f}')
    if args.sweep:
        for min_score in (0.2, 0.3, 0.4, 0.5, 0.6, 0.7):
            config = dataclasses.replace(base, min_score=min_score)
            swept = FingertipDetector(detector.model, config)
            tally = DetectionTally()
            for view in views:
                tally.add(swept.detect(view.image), view.tips_uv, view.tips_visible,
                          radius_px=radius_px)
            print(f'min_score {min_score:.1f}: precision {tally.precision:.3f}, '
                  f'recall {tally.recall:.3f}')


if __name__ == '__main__':
    main()
