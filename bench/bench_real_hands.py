"""Fingertip detector on real hand photos: tips found within 12 px at the photos' native size.

The photos and their hand-labelled tips are test/fixtures/real_hands (tips.yaml says where
the photos come from). Each photo is detected as it is, at the detector's default settings
(the image pyramid of ``vision/detector/detector.py``), and once more with the pyramid off
(``max_levels`` 1, the detector before the pyramid). A labelled tip counts as found when a
detection (at most ``max_detections`` = 5, score >= ``min_score``) lies within 12 px of it;
other detections are false positives (FP). Nothing here was tuned on these photos.

Usage: python bench/bench_real_hands.py [--model PATH] [--labels YAML]
"""
from __future__ import annotations

import argparse
import dataclasses
import statistics
import time
from pathlib import Path

from hand_tracker_ros.vision.detector.detector import DetectorConfig, FingertipDetector
from hand_tracker_ros.vision.detector.real_photos import load_labelled_photos, score_photo

LABELS = Path(__file__).resolve().parent.parent / 'test' / 'fixtures' / 'real_hands' / 'tips.yaml'
RADIUS_PX = 12.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument('--model', default=None)
    parser.add_argument('--labels', default=str(LABELS))
    args = parser.parse_args()
    photos = load_labelled_photos(args.labels)
    base = FingertipDetector.load(args.model, DetectorConfig())
    for title, config in (('pyramid (default)', DetectorConfig()),
                          ('full resolution only', dataclasses.replace(DetectorConfig(),
                                                                       max_levels=1))):
        detector = FingertipDetector(base.model, config)
        print(f'{title}: tips within {RADIUS_PX:.0f} px at native size')
        found = visible = 0
        for photo in photos:
            detector.detect(photo.image)       # warm-up: ONNX Runtime sizes its buffers
            times = []
            for _ in range(5):
                start = time.perf_counter()
                detections = detector.detect(photo.image)
                times.append(1e3 * (time.perf_counter() - start))
            result = score_photo(photo, detections, RADIUS_PX)
            found, visible = found + result.found, visible + result.visible
            height, width = photo.image.shape[:2]
            print(f'  {photo.name:30s} {width}x{height} {photo.skin:6s} found '
                  f'{result.found}/{result.visible}, FP {result.false_positives}, errors '
                  f'{list(result.errors_px)} px, {statistics.median(times):.1f} ms')
        print(f'  total {found}/{visible}')


if __name__ == '__main__':
    main()
