"""Two tracker settings in lock-step on the same observations: time ratio per set and accuracy.

Usage: python bench/lockstep.py BAG [BAG ...] --a KEY=VALUE ... --b KEY=VALUE ...
       [--start truth|search] [--repeats 1]

This machine's speed drifts by up to 1.5x between runs of one command, so two runs of
``bench/bench_tracker.py`` cannot resolve a change of a few per cent. Here both settings run in
one process: each set of a synthetic bag (with ground truth) is observed once, and two
tracking sessions (settings A and B: ``tracker.*`` and ``session.*`` overrides of
:class:`~hand_tracker_ros.pipeline.offline.PipelineConfig`, YAML values) fit it in turn,
the one that goes first alternating from set to set. The drift then cancels in the ratio of
their times per set. It prints, per bag, each setting's mean 3D joint error, LOST sets and
median time per set, and over all bags the median of the per-set ratios B / A with its
quartiles and the number of sets whose estimates differ.

``--start truth`` (default) resets both sessions to the bag's first ground-truth pose and
observes each set with the attention plan of a session tracking with setting A (regions of
interest, fingertips every few sets: the offline path's work); ``--start search`` starts
both from the automatic search and observes every set whole. Observations depend on neither
setting otherwise, so the overrides may not touch the features, the detector or the
attention.
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from hand_tracker_ros.config import from_mapping, overrides
from hand_tracker_ros.errors import ConfigError, HandTrackerError
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.pipeline.frames import frame_sets, ground_truth, load_rig, rig_file
from hand_tracker_ros.pipeline.offline import OfflinePipeline, PipelineConfig
from hand_tracker_ros.status import TrackStatus
from hand_tracker_ros.tracking.attention import Attention, ObservationPlan

_FIT_KEYS = ('tracker.', 'session.')


def _setting(items: list[str]) -> PipelineConfig:
    try:
        values = overrides(items)
    except ConfigError as err:
        raise SystemExit(str(err)) from err
    outside = [key for key in values if not key.startswith(_FIT_KEYS)]
    if outside:
        msg = f'only tracker.* and session.* may differ (the observations are shared): {outside}'
        raise SystemExit(msg)
    return from_mapping(PipelineConfig, values)


def _observations(bag: str, model: HandModel, config: PipelineConfig, search: bool) -> tuple:
    """Every set's observations after the first, its first ground-truth pose and the truth."""
    rig, truth = load_rig(bag, rig_file(bag, None)), ground_truth(bag)
    pipe = OfflinePipeline(model, rig, config)
    attention = Attention(pipe.config.attention, pipe.cameras)
    observed, first = [], None
    for frames in frame_sets(bag, rig):
        if first is None:
            first = np.asarray(truth[frames.stamp_ns].joint_positions)
            pipe.session.reset(first)
            continue
        plan = ObservationPlan.everything() if search else attention.plan(pipe.session)
        observations, _ = pipe.observe(frames, plan)
        if not search:
            pipe.session.step(observations)       # the next set's plan follows this one
        observed.append(observations)
    pipe.close()
    return rig, observed, first, truth


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('bags', nargs='+', help='synthetic bags (with ground truth)')
    parser.add_argument('--a', nargs='*', default=[], metavar='KEY=VALUE')
    parser.add_argument('--b', nargs='*', default=[], metavar='KEY=VALUE')
    parser.add_argument('--start', choices=('truth', 'search'), default='truth')
    parser.add_argument('--repeats', type=int, default=1)
    args = parser.parse_args()
    settings = {'A': _setting(args.a), 'B': _setting(args.b)}
    print(f"A: {' '.join(args.a) or 'defaults'}; B: {' '.join(args.b) or 'defaults'}; "
          f'start: {args.start}')
    model = HandModel.build()
    search = args.start == 'search'
    ratios: list[float] = []
    differ = 0
    for bag in args.bags:
        rig, observed, first, truth = _observations(bag, model, settings['A'], search)
        pipes = {name: OfflinePipeline(model, rig, config) for name, config in settings.items()}
        for repeat in range(args.repeats):
            errors: dict[str, list[float]] = {name: [] for name in pipes}
            lost = dict.fromkeys(pipes, 0)
            seconds: dict[str, list[float]] = {name: [] for name in pipes}
            for pipe in pipes.values():
                pipe.session.reset(None if search else first)
            for k, observations in enumerate(observed):
                order = ['A', 'B'] if (k + repeat) % 2 == 0 else ['B', 'A']
                thetas = {}
                for name in order:
                    start = time.perf_counter()
                    try:
                        result = pipes[name].session.step(observations)
                    except HandTrackerError:          # no hand to start from yet
                        result = None
                    seconds[name].append(time.perf_counter() - start)
                    if result is None:
                        lost[name] += 1
                        continue
                    thetas[name] = result.theta
                    lost[name] += result.status != TrackStatus.TRACKING
                    expected = truth[observations.stamp_ns].keypoints_m
                    errors[name].append(1e3 * float(np.linalg.norm(
                        result.posed.keypoints_m - expected, axis=1).mean()))
                differ += len(thetas) < 2 or not np.array_equal(thetas['A'], thetas['B'])
                ratios.append(seconds['B'][-1] / seconds['A'][-1])
            print(f'{Path(bag).parent.name if Path(bag).name == "bag" else Path(bag).name} '
                  f'(run {repeat + 1}): ' + '; '.join(
                      f'{name} {np.mean(errors[name]):.2f} mm, {lost[name]} LOST, '
                      f'{1e3 * np.median(seconds[name]):.1f} ms' for name in pipes), flush=True)
        for pipe in pipes.values():
            pipe.close()
    r = np.array(ratios)
    print(f'time per set B / A: median {np.median(r):.3f} (quartiles {np.percentile(r, 25):.3f}'
          f'-{np.percentile(r, 75):.3f}) over {r.size} sets; {differ} sets with other estimates')


if __name__ == '__main__':
    main()
