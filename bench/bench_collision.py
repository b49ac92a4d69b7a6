"""Timings of the collision term C on the hand model (median, min, max of repeated calls).

Poses: the neutral open hand (no collision) and the index finger abducted into the middle
finger (a handful of colliding part pairs). Run: ``python bench/bench_collision.py``.
"""
from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from hand_tracker_ros.energies.collision import CollisionConfig, CollisionEnergy
from hand_tracker_ros.geometry import triangle_pairs
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.layout import PARAM_NAMES

REPEATS = 50


def _time_ms(fn: Callable[[], object], repeats: int = REPEATS) -> tuple[float, float, float]:
    fn()  # warm-up (numba compile or cache load)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(1e3 * (time.perf_counter() - t0))
    return float(np.median(times)), float(np.min(times)), float(np.max(times))


def _report(label: str, timing: tuple[float, float, float]) -> None:
    med, lo, hi = timing
    print(f'{label:<48s} median {med:8.3f} ms   min {lo:8.3f}   max {hi:8.3f}')


def main() -> None:
    """Time pair search, constraints, residuals, linearize and the depth metric."""
    model = HandModel.build()
    energy = CollisionEnergy.from_model(CollisionConfig(), model)
    faces, part, adj = energy.faces, energy.face_part, model.adjacent_parts
    print(f'hand mesh: {len(model.rest_vertices_m)} vertices, {len(faces)} faces, '
          f'{len(adj)} parts')
    poses = {'neutral': model.neutral_theta()}
    for angle in (-0.25, -0.3):
        theta = model.neutral_theta()
        theta[PARAM_NAMES.index('index_mcp_abd')] = angle
        poses[f'index_mcp_abd={angle}'] = theta
    for name, theta in poses.items():
        posed = model.pose(theta)
        verts = posed.vertices_m
        pairs = energy.pairs_at(verts)
        n_part_pairs = len(np.unique(part[pairs.face_pairs], axis=0))
        print(f'\npose {name}: {len(pairs.face_pairs)} face pairs over {n_part_pairs} part '
              f'pairs, M = {pairs.n_residuals} residuals')
        _report('intersecting_pairs', _time_ms(
            lambda: triangle_pairs.intersecting_pairs(verts, faces, part, adj)))
        _report('correspond (pairs + constraints)', _time_ms(lambda: energy.pairs_at(verts)))
        _report('residuals', _time_ms(lambda: energy.residuals(posed, pairs)))
        _report('linearize', _time_ms(lambda: energy.linearize(posed, pairs)))
        _report('max_interpenetration_m', _time_ms(
            lambda: triangle_pairs.max_interpenetration_m(verts, faces, part, adj), 10))


if __name__ == '__main__':
    main()
