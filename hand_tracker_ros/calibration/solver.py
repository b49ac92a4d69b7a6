r"""Joint Levenberg-Marquardt over N frame poses and one hand shape.

Unknowns ``z = [theta_1; ...; theta_N; x]`` (N P + S). Frame ``k`` contributes residuals
``r_k(theta_k, x)`` (:class:`~.frame_terms.FrameTerms`), the shape a prior

.. math:: r_p = \sqrt{N w_p} \, (x_j / \bar x_j - 1), \quad j \ne \text{scale}

towards the start shape ``xbar`` (every field but the global scale: the scale and the other
fields are otherwise interchangeable, ``L = s l``, so the prior also fixes that gauge and makes
a uniformly larger hand a larger ``scale``). The Gauss-Newton matrix is block-arrow shaped:
per frame ``A_k = J_theta^T J_theta`` (P x P), ``B_k = J_theta^T J_x`` (P x S), and the shared
``C = sum_k J_x^T J_x + H_p``. Each damped step, with Marquardt's scaling
``D = diag(H)``, eliminates the poses (Schur complement):

.. math::

    (C + \mu D_x - \sum_k B_k^T \tilde A_k^{-1} B_k)\, \delta x
        = -g_x + \sum_k B_k^T \tilde A_k^{-1} g_k, \qquad
    \delta\theta_k = -\tilde A_k^{-1} (g_k + B_k \delta x),
    \quad \tilde A_k = A_k + \mu D_k

Poses are clipped to the joint limits, the shape to ``[0.5, 2] xbar``. A step is kept when the
cost decreases (then ``mu /= 3``), else ``mu *= 4``.

How well the frames constrain each shape field (:func:`shape_uncertainty`): with the poses
eliminated, ``S_x = sum_k (J_x^T J_x - B_k^T A_k^{-1} B_k)`` is the data's information on
``x``; with the residual variance ``sigma^2 = 2 F / (M - N P - S)`` the standard deviation of
field ``j`` is ``sigma sqrt((S_x^{-1})_{jj})`` for the fields other than the scale (with the
scale held, since the data cannot tell it from them) and ``sigma / sqrt((S_x)_{00})`` for the
scale (the others held).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.calibration.frame_terms import FrameTerms
from hand_tracker_ros.config import param
from hand_tracker_ros.model.shape_jacobian import S

_EPS_D = 1e-12
_RELATIVE_FLOOR = 1e-12
_SHAPE_BOX = (0.5, 2.0)


@dataclass(frozen=True)
class SolverConfig:
    """The joint pose and shape fit of one correspondence round."""

    iterations: int = param(6, 'LM iterations per correspondence round', low=1, high=1000)
    prior_weight: float = param(3e4, 'weight per frame of the prior on the relative change of '
                                'every shape field but the scale (cost 0.5 w N (x/xbar-1)^2)',
                                low=0.0, high=1e12)
    tau: float = param(1e-3, 'initial damping relative to diag(J^T J)', low=1e-12, high=1e6)


@dataclass(frozen=True)
class Normal:
    """Gauss-Newton blocks at one point: per frame ``A (N, P, P)``, ``B (N, P, S)``,
    ``g (N, P)``; shared ``C (S, S)``, ``gx (S,)`` (prior included) and the data cost."""

    A: FloatArray
    B: FloatArray
    g: FloatArray
    C: FloatArray
    gx: FloatArray
    Cdata: FloatArray
    cost: float
    n_rows: int


def prior(x: FloatArray, x_bar: FloatArray, weight: float) -> tuple[FloatArray, FloatArray]:
    """Prior residuals (S,) and Jacobian (S, S); row 0 (scale) is zero."""
    scale = np.sqrt(weight) * np.r_[0.0, np.ones(S - 1)]
    return scale * (x / x_bar - 1.0), np.diag(scale / x_bar)


def total_cost(frames: Sequence[FrameTerms], thetas: FloatArray, x: FloatArray,
               x_bar: FloatArray, weight: float) -> tuple[float, float]:
    """(data cost, data + prior cost) ``0.5 |r|^2`` at ``thetas`` (N, P), ``x`` (S,)."""
    data = sum(0.5 * float(np.sum(f.residuals(t, x, jacobian=False)[0] ** 2))
               for f, t in zip(frames, thetas))
    rp, _ = prior(x, x_bar, weight)
    return data, data + 0.5 * float(rp @ rp)


def normal_equations(frames: Sequence[FrameTerms], thetas: FloatArray, x: FloatArray,
                     x_bar: FloatArray, weight: float) -> Normal:
    """The blocks of ``J^T J`` and ``J^T r`` (see the module docstring)."""
    n, p = thetas.shape
    A, B, g = np.zeros((n, p, p)), np.zeros((n, p, S)), np.zeros((n, p))
    C, gx = np.zeros((S, S)), np.zeros(S)
    cost, rows = 0.0, 0
    for k, (frame, theta) in enumerate(zip(frames, thetas)):
        r, J = frame.residuals(theta, x, jacobian=True)
        assert J is not None
        Jt, Jx = J[:, :p], J[:, p:]
        A[k], B[k], g[k] = Jt.T @ Jt, Jt.T @ Jx, Jt.T @ r
        C += Jx.T @ Jx
        gx += Jx.T @ r
        cost += 0.5 * float(r @ r)
        rows += r.size
    rp, Jp = prior(x, x_bar, weight)
    return Normal(A, B, g, C + Jp.T @ Jp, gx + Jp.T @ rp, C, cost, rows)


def damped_step(ne: Normal, mu: float) -> tuple[FloatArray, FloatArray]:
    """Pose steps (N, P) and shape step (S,) of the damped system (Schur complement)."""
    n, p = ne.g.shape
    reduced = ne.C + mu * np.diag(np.maximum(np.diag(ne.C), _EPS_D))
    rhs = -ne.gx.copy()
    solved = []
    for k in range(n):
        Ak = ne.A[k] + mu * np.diag(np.maximum(np.diag(ne.A[k]), _EPS_D))
        factor = scipy.linalg.cho_factor(Ak + _EPS_D * np.eye(p))
        AinvB = scipy.linalg.cho_solve(factor, ne.B[k])
        Ainvg = scipy.linalg.cho_solve(factor, ne.g[k])
        reduced -= ne.B[k].T @ AinvB
        rhs += ne.B[k].T @ Ainvg
        solved.append((AinvB, Ainvg))
    dx = scipy.linalg.solve(reduced, rhs, assume_a='sym')
    dtheta = np.stack([-(Ainvg + AinvB @ dx) for AinvB, Ainvg in solved])
    return dtheta, dx


def fit_round(frames: Sequence[FrameTerms], thetas: FloatArray, x: FloatArray,
              x_bar: FloatArray, lower: FloatArray, upper: FloatArray,
              config: SolverConfig = SolverConfig()) -> tuple[FloatArray, FloatArray, Normal]:
    """LM on poses ``thetas`` (N, P) and shape ``x`` (S,) with the frames' correspondences
    fixed; returns the new poses, shape and the normal equations at them."""
    weight = config.prior_weight * len(frames)
    ne = normal_equations(frames, thetas, x, x_bar, weight)
    cost = total_cost(frames, thetas, x, x_bar, weight)[1]
    mu = config.tau
    for _ in range(config.iterations):
        dtheta, dx = damped_step(ne, mu)
        new_thetas = np.clip(thetas + dtheta, lower, upper)
        new_x = np.clip(x + dx, _SHAPE_BOX[0] * x_bar, _SHAPE_BOX[1] * x_bar)
        new_cost = total_cost(frames, new_thetas, new_x, x_bar, weight)[1]
        if np.isfinite(new_cost) and new_cost < cost:
            thetas, x, cost, mu = new_thetas, new_x, new_cost, mu / 3.0
            ne = normal_equations(frames, thetas, x, x_bar, weight)
        else:
            mu *= 4.0
    return thetas, x, ne


def shape_uncertainty(ne: Normal, x: FloatArray) -> FloatArray:
    """Relative standard deviation (S,) of every shape field from the data alone."""
    n, p = ne.g.shape
    info = ne.Cdata.copy()
    for k in range(n):
        info -= ne.B[k].T @ np.linalg.lstsq(ne.A[k], ne.B[k], rcond=None)[0]
    dof = max(ne.n_rows - n * p - S, 1)
    sigma2 = 2.0 * ne.cost / dof
    # A direction the data never sees keeps a vanishing eigenvalue (so a huge variance),
    # not the zero variance a pseudo-inverse would give it.
    floor = _RELATIVE_FLOOR * max(float(np.max(np.diag(info))), _EPS_D)
    std = np.empty(S)
    std[0] = np.sqrt(sigma2 / max(info[0, 0], floor))
    rest = info[1:, 1:] + floor * np.eye(S - 1)
    std[1:] = np.sqrt(sigma2 * np.maximum(np.diag(np.linalg.inv(rest)), 0.0))
    return std / np.abs(x)
