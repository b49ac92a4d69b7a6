"""Per-camera image features: ms per camera-frame at 320x240 and 640x480.

Frames: a low-saturation textured background with a skin-coloured hand-like blob (palm
ellipse + 5 finger capsules) that moves and rotates a little between frames, plus sensor
noise. Each figure is the median (min-max) of timed batches; a batch repeats the call until it
lasts ~0.1 s, after 2 warm-up calls. Run: ``python bench/bench_features.py``.
"""
from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable

import cv2
import numpy as np

from hand_tracker_ros.vision.edges import EdgeConfig, compute_edges
from hand_tracker_ros.vision.features import FeatureExtractor, FeaturesConfig, MultiCameraFeatures
from hand_tracker_ros.vision.flow import FlowConfig, FlowEstimator
from hand_tracker_ros.vision.image import to_gray
from hand_tracker_ros.vision.mask import ForegroundMasker, MaskConfig

SKIN_RGB = (224, 172, 140)


def background(rng: np.random.Generator, height: int, width: int) -> np.ndarray:
    """(H, W, 3) uint8 textured, low-saturation background at two scales."""
    fine = cv2.GaussianBlur(rng.normal(0.0, 50.0, (height, width)), (0, 0), 1.5)
    coarse = cv2.resize(rng.normal(0.0, 40.0, (height // 16, width // 16)), (width, height))
    tint = cv2.GaussianBlur(rng.normal(0.0, 8.0, (height, width, 3)), (0, 0), 3.0)
    return np.clip(128.0 + fine[..., None] + coarse[..., None] + tint, 0, 255).astype(np.uint8)


def hand_frame(bg: np.ndarray, t: int, rng: np.random.Generator) -> np.ndarray:
    """The background with a hand-like skin blob at time step ``t``, plus noise."""
    height, width = bg.shape[:2]
    s = width / 320.0
    cu, cv_ = width / 2 + 2.5 * s * t, height / 2 + 1.5 * s * t
    angle = 0.03 * t
    img = bg.copy()
    cv2.ellipse(img, (int(cu), int(cv_)), (int(28 * s), int(34 * s)),
                np.degrees(angle), 0, 360, SKIN_RGB, -1)
    for k, (phi, length) in enumerate(zip((-1.2, -0.5, -0.15, 0.2, 0.55),
                                          (35, 50, 55, 50, 40))):
        a = angle + phi - np.pi / 2
        p0 = (cu + 25 * s * np.cos(a), cv_ + 30 * s * np.sin(a))
        p1 = (p0[0] + length * s * np.cos(a), p0[1] + length * s * np.sin(a))
        shade = tuple(int(c - 6 * k) for c in SKIN_RGB)
        cv2.line(img, tuple(map(int, p0)), tuple(map(int, p1)), shade, int(12 * s),
                 cv2.LINE_AA)
    noise = rng.normal(0.0, 3.0, img.shape)
    return np.clip(img + noise, 0, 255).astype(np.uint8)


def timed(fn: Callable[[], object], batches: int = 7, batch_s: float = 0.1) -> list[float]:
    """ms per call of each batch (2 warm-up calls first)."""
    fn()
    fn()
    out = []
    for _ in range(batches):
        n, t0 = 0, time.perf_counter()
        while True:
            fn()
            n += 1
            elapsed = time.perf_counter() - t0
            if elapsed >= batch_s:
                break
        out.append(1e3 * elapsed / n)
    return out


def report(label: str, ms: list[float]) -> None:
    print(f'  {label:<52s} {statistics.median(ms):7.3f} ms  '
          f'({min(ms):.3f}-{max(ms):.3f})')


def bench_size(width: int, height: int) -> None:
    rng = np.random.default_rng(0)
    bg = background(rng, height, width)
    frames = [hand_frame(bg, t, rng) for t in range(8)]
    grays = [to_gray(f) for f in frames]
    print(f'{width}x{height}, one camera, cv2 threads 1:')
    report('gray conversion', timed(lambda: to_gray(frames[1])))
    report('edges (blur+Sobel+Canny+orientation)',
           timed(lambda: compute_edges(grays[1], EdgeConfig())))
    skin = ForegroundMasker(MaskConfig(method='skin'))
    report('mask skin (CrCb LUT + open/close)', timed(lambda: skin.compute(frames[1])))
    bgm = ForegroundMasker(MaskConfig(method='background'))
    bgm.set_background(bg)
    report('mask background (absdiff + open/close)', timed(lambda: bgm.compute(frames[1])))
    for preset in ('ultrafast', 'fast'):
        dis = FlowEstimator(FlowConfig(method='dis', dis_preset=preset))
        report(f'flow DIS {preset}', timed(lambda: dis.compute(grays[0], grays[1])))
    lk = FlowEstimator(FlowConfig(method='lk'))
    report('flow LK (300 corners, win 15, 2 levels, fwd-bwd)',
           timed(lambda: lk.compute(grays[0], grays[1])))
    # A hand-sized box (256x256 at 640x480) around the blob, clipped to the image.
    side = 256 * width // 640
    roi = (width // 2 - side // 2, height // 2 - side // 2,
           width // 2 + side // 2, height // 2 + side // 2)
    for method, roi_px in (('dis', None), ('lk', None), ('dis', roi)):
        ex = FeatureExtractor('cam0', FeaturesConfig(flow=FlowConfig(method=method)))
        state = {'t': 0}

        def step(ex: FeatureExtractor = ex, roi_px: tuple[int, ...] | None = roi_px) -> None:
            state['t'] += 1
            ex.process(frames[state['t'] % len(frames)], state['t'], roi_px=roi_px)
        where = 'full image' if roi_px is None else f'{side}x{side} ROI'
        report(f'whole extractor (skin, {method} flow, {where})', timed(step))
    bench_cameras(frames, 4, None)
    bench_cameras(frames, 4, roi)


def bench_cameras(frames: list[np.ndarray], n_cams: int,
                  roi: tuple[int, int, int, int] | None) -> None:
    """4 cameras in the 2-thread pool vs one after the other."""
    where = '' if roi is None else f', {roi[2] - roi[0]}x{roi[3] - roi[1]} ROI'
    state = {'t': 0}
    with MultiCameraFeatures([f'cam{i}' for i in range(n_cams)], FeaturesConfig()) as mc:

        def multi() -> None:
            state['t'] += 1
            mc.process([frames[state['t'] % len(frames)]] * n_cams, state['t'],
                       rois_px=[roi] * n_cams)
        ms = timed(multi)
    report(f'{n_cams} cams, 2-thread pool, per frame{where}', ms)
    report(f'{n_cams} cams, 2-thread pool, per camera-frame{where}', [m / n_cams for m in ms])
    extractors = [FeatureExtractor(f'seq{i}', FeaturesConfig()) for i in range(n_cams)]

    def sequential() -> None:
        state['t'] += 1
        for ex in extractors:
            ex.process(frames[state['t'] % len(frames)], state['t'], roi_px=roi)
    report(f'{n_cams} cams, sequential, per frame{where}', timed(sequential))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--sizes', default='320x240,640x480')
    args = parser.parse_args()
    cv2.setNumThreads(1)
    for size in args.sizes.split(','):
        width, height = (int(x) for x in size.split('x'))
        bench_size(width, height)


if __name__ == '__main__':
    main()
