"""Box-constrained Levenberg-Marquardt on an analytic Jacobian.

We minimise ``F(x) = 0.5 |r(x)|^2`` over ``lower <= x <= upper``, optionally over a subset of
*free* parameters (coarse-to-fine schedules freeze the distal finger joints). With
``A = J^T J`` and ``g = J^T r`` at the current ``x``, each iteration solves the damped normal
equations (Marquardt's scaling, [Marquardt63])::

    (A + mu * D) delta = -g,    D = diag(max(diag(A), eps_D))

restricted to the free parameters, and projects the step onto the box,
``x' = clip(x + delta, lower, upper)`` (the projection used by levmar's ``dlevmar_bc_der`` in
spirit; it keeps every trial pose within the joint limits). The gain ratio

    rho = (F(x) - F(x')) / (-(g . d + 0.5 d^T A d)),   d = x' - x

decides: ``rho > 0`` accepts the step and relaxes the damping,
``mu *= max(1/3, 1 - (2 rho - 1)^3)``; otherwise ``mu *= nu, nu *= 2`` [Nielsen99]. Because
``D`` already carries the scale of every parameter (metres and radians differ by orders of
magnitude in ``A``), the first damping is the dimensionless ``mu = tau``; levmar's
``tau * max(diag(A))`` belongs to the unscaled ``D = I`` and would freeze the small-scale
parameters when translations dominate ``A``.

Why hand-written rather than ``scipy.optimize.least_squares``: scipy forces an explicit J and runs
a QR of it every iteration (5-8x the cost of the normal equations for our 26 columns and 10k-50k
rows, measured when it was written), has no per-iteration hook for frozen parameters, and its
``'lm'`` method takes no bounds.

A step whose mean absolute change of the angular parameters exceeds ``max_mean_step_rad``
(Ballan's code: 30 degrees) is treated as divergent and rejected like a cost increase.

References (docs/references.md): [Marquardt63] D. Marquardt, SIAM J. Appl. Math. 11(2), 1963.
[Nielsen99] H. B. Nielsen, "Damping parameter in Marquardt's method", IMM-REP-1999-05.
"""
from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from enum import IntEnum

import numpy as np
import scipy.linalg

from hand_tracker_ros._typing import BoolArray, FloatArray
from hand_tracker_ros.checks import check_shape
from hand_tracker_ros.config import param
from hand_tracker_ros.errors import ShapeError

LOG = logging.getLogger(__name__)

ResidualFunction = Callable[[FloatArray, bool], tuple[FloatArray, FloatArray | None]]


class FitStatus(IntEnum):
    """Why the solver stopped; ``> 0`` means converged."""

    NON_FINITE = -1
    MAX_ITERATIONS = 0
    COST_CONVERGED = 1
    STEP_CONVERGED = 2
    DAMPING_EXHAUSTED = 3


MESSAGES = {
    FitStatus.NON_FINITE: 'residuals or Jacobian are not finite at the initial point',
    FitStatus.MAX_ITERATIONS: 'the iteration limit was reached',
    FitStatus.COST_CONVERGED: 'the relative cost decrease fell below `ftol`',
    FitStatus.STEP_CONVERGED: 'the step fell below `xtol`',
    FitStatus.DAMPING_EXHAUSTED: 'no decreasing step was found (damping reached its limit)',
}


@dataclass(frozen=True)
class LMConfig:
    """Levenberg-Marquardt settings."""

    max_iterations: int = param(10, 'LM iterations per call at most (Ballan: 10); the tracker '
                                "runs schedule.iterations per round and separation.iterations "
                                'per separation round, each capped by this', low=1, high=1000)
    tau: float = param(1e-3, 'initial damping, relative to diag(J^T J)', low=1e-12, high=1e6)
    # Within a tracker's round (correspondences fixed) the first step takes nearly all of the
    # decrease, and later ones gain hundredths of a per cent, so a round (and a separation
    # round) stops after an accepted step that gains less than 0.1 %. Against 1e-6, in
    # bench/lockstep.py on held-out bags, the fits took 0.91-0.92 of the time with the same
    # error, from the true pose and from the search. 1e-2 took 0.90 but refined a live
    # search's rough find more slowly (docs/history.md, "Session of 2026-11-26 (eighth)").
    ftol: float = param(1e-3, 'stop when an accepted step decreases the cost by less than '
                        'this fraction of it', low=0.0, high=1.0)
    xtol: float = param(1e-7, 'stop when the step norm is below this', low=0.0, high=1.0)
    max_mean_step_rad: float = param(0.5236, 'reject steps whose mean angular change exceeds '
                                     'this (Ballan: 30 deg)', unit='rad', low=0.0, high=10.0)
    max_damping: float = param(1e12, 'give up when the damping exceeds this', low=1.0)


@dataclass(frozen=True)
class FitResult:
    """Outcome of one solver call."""

    x: FloatArray               # (P,) solution
    cost: float                 # 0.5 |r(x)|^2
    initial_cost: float         # 0.5 |r(x0)|^2
    status: FitStatus
    n_iterations: int           # iterations that ran (accepted or not)
    n_evaluations: int          # residual evaluations

    @property
    def success(self) -> bool:
        """True when the solver converged (status > 0)."""
        return self.status > 0

    @property
    def message(self) -> str:
        """Human-readable termination reason."""
        return MESSAGES[self.status]


def _validate(x0: FloatArray, lower: FloatArray, upper: FloatArray,
              free: BoolArray | None) -> BoolArray:
    check_shape('lower', lower, x0.shape)
    check_shape('upper', upper, x0.shape)
    if np.any(lower > upper):
        msg = '`lower` must not exceed `upper`'
        raise ShapeError(msg)
    if free is None:
        return np.ones(x0.shape, bool)
    check_shape('free', free, x0.shape)
    return np.asarray(free, bool)


def _damped_step(A: FloatArray, g: FloatArray, mu: float, free: BoolArray) -> FloatArray:
    """Solve ``(A + mu D) delta = -g`` on the free parameters (Cholesky)."""
    Af = A[np.ix_(free, free)]
    D = np.maximum(np.diag(Af), 1e-9 * max(1.0, float(np.max(np.diag(Af), initial=0.0))))
    delta = np.zeros_like(g)
    try:
        factor = scipy.linalg.cho_factor(Af + mu * np.diag(D))
        delta[free] = -scipy.linalg.cho_solve(factor, g[free])
    except (np.linalg.LinAlgError, scipy.linalg.LinAlgError):
        delta[free] = -np.linalg.lstsq(Af + mu * np.diag(D), g[free], rcond=None)[0]
    return delta


def levenberg_marquardt(fun: ResidualFunction, x0: FloatArray, lower: FloatArray,
                        upper: FloatArray, *, config: LMConfig = LMConfig(),
                        free: BoolArray | None = None,
                        angular: BoolArray | None = None) -> FitResult:
    """Minimise ``0.5 |fun(x)|^2`` within bounds.

    Parameters
    ----------
    fun : callable
        ``fun(x, jacobian) -> (r (M,), J (M, P) or None)``; J is only needed when
        ``jacobian`` is True. M must not change between calls.
    x0, lower, upper : (P,) float64
        Start point (clipped into the box) and bounds.
    config : LMConfig
    free : (P,) bool, optional
        Parameters the solver may change (default all).
    angular : (P,) bool, optional
        Parameters counted by the ``max_mean_step_rad`` divergence guard (default none).
    """
    x0 = np.asarray(x0, np.float64)
    free = _validate(x0, lower, upper, free)
    guard = np.zeros(x0.shape, bool) if angular is None else np.asarray(angular, bool) & free
    x = np.clip(x0, lower, upper)
    r, J = fun(x, True)
    n_eval = 1
    if not (np.all(np.isfinite(r)) and J is not None and np.all(np.isfinite(J))):
        return FitResult(x, float('nan'), float('nan'), FitStatus.NON_FINITE, 0, n_eval)
    cost = initial_cost = 0.5 * float(r @ r)
    A, g = J.T @ J, J.T @ r
    mu = config.tau
    nu = 2.0
    status = FitStatus.MAX_ITERATIONS
    iteration = 0
    while iteration < config.max_iterations:
        iteration += 1
        step = np.clip(x + _damped_step(A, g, mu, free), lower, upper) - x
        if np.linalg.norm(step) <= config.xtol * (np.linalg.norm(x) + config.xtol):
            status = FitStatus.STEP_CONVERGED
            break
        predicted = -(g @ step + 0.5 * step @ A @ step)
        divergent = guard.any() and np.mean(np.abs(step[guard])) > config.max_mean_step_rad
        # The trial point comes with its Jacobian: nearly every step of a warm-started
        # tracker is accepted, and evaluating r alone first would pose the hand twice there.
        # The last iteration's Jacobian would never be read.
        last = iteration == config.max_iterations
        r_new, J_new = (r, J) if divergent else fun(x + step, not last)
        n_eval += 0 if divergent else 1
        cost_new = 0.5 * float(r_new @ r_new) if np.all(np.isfinite(r_new)) else np.inf
        rho = (cost - cost_new) / predicted if predicted > 0 and not divergent else -1.0
        if rho > 0:
            x = x + step
            r, J = r_new, J_new
            if not last:
                assert J is not None   # evaluated with its Jacobian unless last
                A, g = J.T @ J, J.T @ r
            converged = (cost - cost_new) <= config.ftol * cost
            cost = cost_new
            mu *= max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
            nu = 2.0
            if converged:
                status = FitStatus.COST_CONVERGED
                break
        else:
            mu *= nu
            nu *= 2.0
            if mu > config.max_damping:
                status = FitStatus.DAMPING_EXHAUSTED
                break
    LOG.debug('LM: cost %.4g -> %.4g in %d iterations (%s)', initial_cost, cost, iteration,
              MESSAGES[status])
    return FitResult(x, cost, initial_cost, status, iteration, n_eval)
