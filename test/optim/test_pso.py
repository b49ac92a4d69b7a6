"""PSO finds the minimum of smooth test functions; determinism; frozen parameters."""
from __future__ import annotations

import numpy as np

from hand_tracker_ros.optim.pso import PSOConfig, particle_swarm


def sphere_factory(target: np.ndarray):
    def cost_at(anchor: np.ndarray):
        return lambda X: np.sum((X - target) ** 2, axis=1)
    return cost_at


def test_pso_converges_on_a_shifted_sphere() -> None:
    target = np.array([0.3, -0.2, 0.5, 0.1])
    res = particle_swarm(sphere_factory(target), np.zeros(4), np.full(4, -1.0), np.ones(4),
                         np.full(4, 0.3), config=PSOConfig(particles=32, generations=60))
    np.testing.assert_allclose(res.x, target, atol=1e-3)
    assert res.cost < 1e-5


def test_pso_respects_bounds_frozen_parameters_and_seed() -> None:
    target = np.array([2.0, 2.0, 2.0])
    kwargs = dict(config=PSOConfig(particles=16, generations=20, seed=3),
                  free=np.array([True, True, False]))
    a = particle_swarm(sphere_factory(target), np.zeros(3), np.full(3, -1.0), np.ones(3),
                       np.full(3, 0.5), **kwargs)
    b = particle_swarm(sphere_factory(target), np.zeros(3), np.full(3, -1.0), np.ones(3),
                       np.full(3, 0.5), **kwargs)
    np.testing.assert_array_equal(a.x, b.x)
    assert a.x[2] == 0.0
    np.testing.assert_allclose(a.x[:2], [1.0, 1.0], atol=1e-6)   # pinned at the upper bound


def test_more_generations_do_not_hurt_on_rosenbrock() -> None:
    def cost_at(anchor):
        return lambda X: 100.0 * (X[:, 1] - X[:, 0] ** 2) ** 2 + (1.0 - X[:, 0]) ** 2
    costs = [particle_swarm(cost_at, np.array([-1.0, 1.0]), np.full(2, -2.0), np.full(2, 2.0),
                            np.full(2, 0.5), config=PSOConfig(particles=24, generations=g)).cost
             for g in (5, 80)]
    assert costs[1] <= costs[0] and costs[1] < 1e-3
