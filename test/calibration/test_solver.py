"""The joint pose-and-shape solver: Schur step, uncertainty, frame selection."""
from __future__ import annotations

import numpy as np

from hand_tracker_ros.calibration.calibrate import select_frames
from hand_tracker_ros.calibration.solver import Normal, damped_step, shape_uncertainty
from hand_tracker_ros.model.layout import P
from hand_tracker_ros.model.shape import HandShape
from hand_tracker_ros.model.shape_jacobian import S


def _normal(rng: np.random.Generator, n: int, dead_column: int | None = None) -> Normal:
    """The normal equations of random Jacobians of ``n`` frames (and their dense system)."""
    jacs = [rng.normal(size=(200, P + S)) for _ in range(n)]
    rs = [rng.normal(size=200) for _ in range(n)]
    if dead_column is not None:
        for J in jacs:
            J[:, P + dead_column] = 0.0
    Jx = [J[:, P:] for J in jacs]
    data = sum(j.T @ j for j in Jx)
    prior = np.diag(np.r_[0.0, np.full(S - 1, 1e-3)])
    return Normal(A=np.stack([J[:, :P].T @ J[:, :P] for J in jacs]),
                  B=np.stack([J[:, :P].T @ J[:, P:] for J in jacs]),
                  g=np.stack([J[:, :P].T @ r for J, r in zip(jacs, rs)]),
                  C=data + prior, gx=sum(j.T @ r for j, r in zip(Jx, rs)), Cdata=data,
                  cost=0.5 * sum(float(r @ r) for r in rs), n_rows=200 * n)


def test_schur_step_solves_the_dense_system() -> None:
    rng = np.random.default_rng(3)
    ne, n, mu = _normal(rng, 3), 3, 0.1
    size = n * P + S
    H, g = np.zeros((size, size)), np.zeros(size)
    for k in range(n):
        sl = slice(k * P, (k + 1) * P)
        H[sl, sl], H[sl, n * P:], H[n * P:, sl] = ne.A[k], ne.B[k], ne.B[k].T
        g[sl] = ne.g[k]
    H[n * P:, n * P:], g[n * P:] = ne.C, ne.gx
    dense = np.linalg.solve(H + mu * np.diag(np.diag(H)), -g)
    dtheta, dx = damped_step(ne, mu)
    np.testing.assert_allclose(np.r_[dtheta.ravel(), dx], dense, rtol=1e-8, atol=1e-10)


def test_a_field_the_data_never_sees_is_unconstrained() -> None:
    rng = np.random.default_rng(4)
    x = HandShape().to_vector()
    seen = shape_uncertainty(_normal(rng, 3), x)
    blind = shape_uncertainty(_normal(rng, 3, dead_column=5), x)
    assert np.all(np.isfinite(seen))
    assert blind[5] > 1e3 * seen[5]
    np.testing.assert_allclose(np.delete(blind, 5), np.delete(seen, 5), rtol=0.5)


def test_select_frames_spreads_and_starts_at_the_most_confident() -> None:
    thetas = np.zeros((6, P))
    thetas[:, 10] = [0.0, 0.01, 1.0, 1.01, 2.0, 0.02]
    picked = select_frames(thetas, np.array([0.1, 0.9, 0.2, 0.2, 0.2, 0.2]), 3)
    np.testing.assert_array_equal(picked, [1, 2, 4])


def test_unconstrained_lengths_are_judged_in_millimetres() -> None:
    from hand_tracker_ros.calibration.calibrate import (
        CalibrationConfig,
        CalibrationResult,
        unconstrained_fields,
    )
    from hand_tracker_ros.cli.calibrate import report

    x = HandShape(scale=1.1).to_vector()
    std = np.full(S, 0.01)
    std[-2] = 0.2                            # pinky distal: 0.2 * 17.7 mm * 1.1 = 3.9 mm
    std[5] = 0.04                            # thumb distal: 0.04 * 30 mm * 1.1 = 1.3 mm
    config = CalibrationConfig(warn_std_m=0.0015, warn_relative_std=0.03)
    assert unconstrained_fields(std, x, config) == ('pinky_distal_m',)
    std[0] = 0.05
    loose = unconstrained_fields(std, x, config)
    assert loose == ('scale', 'pinky_distal_m')
    result = CalibrationResult(HandShape.from_vector(x), HandShape(), (1, 2), np.zeros((2, P)),
                               {'edges': (2.0, 100)}, {'edges': (1.0, 120)}, std, loose, 40)
    warnings = [line for line in report(result).splitlines() if line.startswith('warning')]
    assert len(warnings) == 2 and 'pinky_distal_m (+-3.53 mm' in warnings[1]
