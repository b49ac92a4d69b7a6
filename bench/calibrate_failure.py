"""Calibrate the failure detector: fit the confidence's logistic weights to ground truth.

Tracks synthetic random-motion sequences with the failure policy switched off (no recovery,
nothing LOST, so every frame keeps the plain fit, good or bad), records each frame's image
evidence (:mod:`hand_tracker_ros.tracking.evidence`) and its mean 3D joint error, and fits
``p = sigmoid(b + w . x)`` to the label "error < 15 mm" by L2-regularised logistic regression
(scipy BFGS). Each sequence runs twice: from the ground-truth first pose and from the
automatic start (which lands in wrong basins now and then, the failures to learn from).
Prints the fitted bias and weights (``session.evidence.bias`` / ``weights``) and, on the
held-out seeds, the share of frames > 30 mm with p < 0.5 (recall) and of frames < 10 mm with
p < 0.5 (false alarms).

    python bench/calibrate_failure.py [--frames 150] [--fit-seeds 11 13] [--test-seeds 14]
"""
from __future__ import annotations

import argparse
import multiprocessing
from dataclasses import replace

import numpy as np
from scipy.optimize import minimize

from hand_tracker_ros.config import from_mapping
from hand_tracker_ros.core.frames import FrameSet
from hand_tracker_ros.evaluation.metrics import joint_errors_mm
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.pipeline.offline import OfflinePipeline, PipelineConfig
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence
from hand_tracker_ros.tracking.evidence import SIGNALS

# Conditions of the fit: those of the robustness suite (evaluation/robustness.py).
CONDITIONS = ({}, {'n_cameras': 2}, {'fps': 15.0}, {'noise_sigma': 12.0}, {'clutter': 40})
NO_POLICY = {'session.recovery': False, 'session.failure.lost_below': 0.0}


def _record(job: tuple[int, dict, bool, int]) -> tuple[np.ndarray, np.ndarray]:
    """Evidence (T, S) and error (T,) mm of one sequence."""
    seed, condition, from_truth, frames = job
    model = HandModel.build()
    sequence = SyntheticSequence(replace(SynthConfig(motion='random', seed=seed,
                                                     n_frames=frames), **condition), model)
    pipeline = OfflinePipeline(model, sequence.rig, from_mapping(PipelineConfig, NO_POLICY))
    if from_truth:
        pipeline.session.reset(sequence.thetas[0])
    x, e = [], []
    try:
        for frame in sequence:
            result = pipeline.step(FrameSet(frame.stamp_ns, frame.images))
            x.append([result.evidence[name] for name in SIGNALS])
            e.append(joint_errors_mm(result.posed.keypoints_m[None], frame.keypoints_m[None])[0])
    finally:
        pipeline.close()
    return np.array(x), np.array(e)


def _data(seeds: list[int], frames: int, workers: int) -> tuple[np.ndarray, np.ndarray]:
    jobs = [(s, c, t, frames) for s in seeds for c in CONDITIONS for t in (True, False)]
    with multiprocessing.get_context('fork').Pool(workers) as pool:
        parts = pool.map(_record, jobs, chunksize=1)
    return np.vstack([p[0] for p in parts]), np.concatenate([p[1] for p in parts])


def fit_logistic(x: np.ndarray, y: np.ndarray, l2: float = 0.01) -> np.ndarray:
    """``(b, w_1..w_S)`` minimising the logistic loss of labels ``y`` (1 good) plus
    ``l2 |w|^2``."""
    def loss(params: np.ndarray) -> float:
        z = params[0] + x @ params[1:]
        return float(np.sum(y * np.logaddexp(0, -z) + (1 - y) * np.logaddexp(0, z))
                     + l2 * params[1:] @ params[1:])
    return minimize(loss, np.zeros(x.shape[1] + 1), method='BFGS').x


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--frames', type=int, default=150)
    parser.add_argument('--fit-seeds', type=int, nargs='+', default=[11, 13])
    parser.add_argument('--test-seeds', type=int, nargs='+', default=[14])
    parser.add_argument('--workers', type=int, default=2)
    args = parser.parse_args()
    x, e = _data(args.fit_seeds, args.frames, args.workers)
    params = fit_logistic(x, (e < 15.0).astype(float))
    print(f'{len(e)} frames ({np.sum(e > 30)} > 30 mm, {np.sum(e < 10)} < 10 mm)')
    print(f'bias {params[0]:.2f}  weights ' + ', '.join(
        f'{n} {w:.2f}' for n, w in zip(SIGNALS, params[1:])))
    for name, seeds in (('fit', args.fit_seeds), ('held-out', args.test_seeds)):
        xs, es = (x, e) if name == 'fit' else _data(seeds, args.frames, args.workers)
        lost = params[0] + xs @ params[1:] < 0.0          # p < 0.5
        recall = np.mean(lost[es > 30]) if np.any(es > 30) else float('nan')
        print(f'{name} seeds {seeds}: {len(es)} frames, recall (> 30 mm flagged) {recall:.3f}, '
              f'false alarms (< 10 mm flagged) {np.mean(lost[es < 10]):.4f}')


if __name__ == '__main__':
    main()
