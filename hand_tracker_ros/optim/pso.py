"""Particle swarm optimisation, the HOPE baseline (Oikonomidis et al., BMVC 2011).

HOPE tracks a hand by rendering hypotheses and evolving them with a canonical PSO with
constriction factor [Clerc02]: for particle ``i`` with position ``x_i``, velocity ``v_i``,
personal best ``p_i`` and swarm best ``g``,

    v_i <- chi * (v_i + c1 * U(0,1) * (p_i - x_i) + c2 * U(0,1) * (g - x_i))
    x_i <- clip(x_i + v_i, lower, upper)

with ``chi = 0.7298``, ``c1 = c2 = 2.05`` and, in the released tracker, 64 particles x 25
generations, the swarm initialised around the previous frame's solution with per-parameter
spreads. We minimise the *same* objective as the LM tracker. Because every energy needs
correspondences found at a pose, the objective is rebuilt once per generation at the swarm's
best pose (``cost_at(g)``) and all particles of that generation are scored with it; this keeps
a generation's comparisons consistent and costs one correspondence search per generation.

[Clerc02] M. Clerc, J. Kennedy, IEEE Trans. Evol. Comput. 6(1), 2002.

References: docs/references.md.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from hand_tracker_ros._typing import BoolArray, FloatArray
from hand_tracker_ros.checks import check_shape
from hand_tracker_ros.config import param

# cost_at(anchor) returns a batch cost function f(X (N, P)) -> (N,) built at pose `anchor`.
CostFactory = Callable[[FloatArray], Callable[[FloatArray], FloatArray]]


@dataclass(frozen=True)
class PSOConfig:
    """Swarm size and dynamics (defaults: HOPE's released tracker)."""

    particles: int = param(64, 'particles per generation', low=2, high=10000)
    generations: int = param(25, 'generations per frame', low=1, high=10000)
    constriction: float = param(0.7298, 'constriction factor chi', low=0.0, high=1.0)
    cognitive: float = param(2.05, 'attraction to the personal best c1', low=0.0, high=5.0)
    social: float = param(2.05, 'attraction to the swarm best c2', low=0.0, high=5.0)
    seed: int = param(0, 'random seed of the swarm', low=0)


@dataclass(frozen=True)
class PSOResult:
    """Best pose found and its cost under the last generation's objective."""

    x: FloatArray       # (P,)
    cost: float
    evaluations: int


def particle_swarm(cost_at: CostFactory, x0: FloatArray, lower: FloatArray, upper: FloatArray,
                   spread: FloatArray, *, config: PSOConfig = PSOConfig(),
                   free: BoolArray | None = None) -> PSOResult:
    """Minimise a (re-anchored) batch cost with a constricted PSO.

    Parameters
    ----------
    cost_at : callable
        ``cost_at(anchor (P,)) -> f``, with ``f(X (N, P)) -> (N,)`` the costs of N poses.
    x0 : (P,) float64
        Centre of the initial swarm (e.g. the previous frame's pose); particle 0 is x0 itself.
    lower, upper : (P,) float64
        Bounds.
    spread : (P,) float64
        Std of the Gaussian initial scatter per parameter (units of the parameter).
    free : (P,) bool, optional
        Parameters the swarm explores (others stay at x0).
    """
    check_shape('spread', spread, x0.shape)
    free = np.ones(x0.shape, bool) if free is None else np.asarray(free, bool)
    rng = np.random.default_rng(config.seed)
    n = config.particles
    scatter = rng.normal(0.0, 1.0, (n, x0.size)) * spread * free
    scatter[0] = 0.0
    x = np.clip(x0 + scatter, lower, upper)
    v = np.zeros_like(x)
    best_x, best_f = x.copy(), np.full(n, np.inf)
    g = x0.copy()
    evaluations = 0
    for _ in range(config.generations):
        f = cost_at(g)
        # Personal bests are re-scored under this generation's objective so comparisons agree.
        fx, fb = f(x), f(best_x)
        evaluations += 2 * n
        improved = fx < fb
        best_x[improved] = x[improved]
        best_f = np.where(improved, fx, fb)
        g = best_x[int(np.argmin(best_f))].copy()
        r1, r2 = rng.random((2, n, x0.size))
        v = config.constriction * (v + config.cognitive * r1 * (best_x - x)
                                   + config.social * r2 * (g - x)) * free
        x = np.clip(x + v, lower, upper)
    return PSOResult(g, float(np.min(best_f)), evaluations)
