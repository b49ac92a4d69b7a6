r"""Volume collision: overlapping balls of the sphere mesh, the deep-contact backstop of C.

Why a second collision term: the cone distance field (:mod:`.collision`) acts on the
triangles that intersect, i.e. on the ring where two surfaces cross, and pushes along the
receiver faces' normals. That is right for shallow contact, but once a part has sunk about
a finger radius into another, the field can stall:
Levenberg-Marquardt on the cone term alone, started from a frame of the LO+EC ablation row
with a thumb tip 7.3 mm inside the middle finger, still left it 7.3 mm deep after 12 rounds
of 10 iterations. Our hand is a sphere mesh (Tkach et al. 2016), whose solid is the union of
interpolated balls, so the overlap of two balls measures depth everywhere and
always pushes their centres apart: the collision energy of htrack / hmodel
(``chi(i, j) (d_ij - (r_i + r_j))^2``, papers.md section 3) on sampled balls.

Balls: every pill ``(a, b)`` (a finger bone) is sampled at ``samples`` evenly spaced
``t in [0, 1]``, centre ``(1 - t) c_a + t c_b`` and radius ``(1 - t) r_a + t r_b``; every
palm wedge ``(a, b, c)`` at the barycentric points of a grid with ``samples`` points per
side. Each ball is a fixed linear combination ``W`` (N, S) of the S sphere centres, so its
centre's Jacobian is ``W`` applied to ``posed.sphere_centers_jac``.

Pairs: balls of non-adjacent parts (bones) that do not overlap by more than ``margin_m`` in
the rest pose; where the rest pose already fuses two balls, the skin there is one surface and
there is nothing to separate. With ``d_ij = |c_i - c_j|`` and ``u = (c_i - c_j) / d_ij``::

    r_ij = max(0, r_i + r_j - margin - d_ij)               (m)
    dr_ij/dtheta = -u^T (dc_i/dtheta - dc_j/dtheta)        where r_ij > 0, else 0

``margin_m`` lets the cone field alone handle contacts up to that depth (the term is a
backstop, zero on the ground truth of the benchmark motions; see the test). The pairs of a
round are those with ``r_i + r_j - margin - d_ij > -reach_m`` at its start, so a pair
that comes into contact during the round's steps is already in the residual vector.

References: docs/references.md.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hand_tracker_ros._typing import BoolArray, FloatArray, IntArray
from hand_tracker_ros.checks import check_shape
from hand_tracker_ros.config import param
from hand_tracker_ros.core.context import RoundContext
from hand_tracker_ros.model.hand import HandModel, PosedHand
from hand_tracker_ros.model.layout import P

NAME = 'volume'


@dataclass(frozen=True)
class VolumeCollisionConfig:
    """Switch, weight and sampling of the volume collision term."""

    enabled: bool = param(True, 'Use the volume collision term (switched with the collision '
                          'term C in the ablation)')
    weight: float = param(1e10, 'term weight (cost = 0.5 * weight * |r|^2, r in m; 1e10 makes '
                          '1 mm of overlap cost like 100 px on one image point: a near-hard '
                          'constraint)', low=0.0, high=1e14)
    samples: int = param(4, 'balls per pill, and per side of the barycentric grid of a palm '
                         'wedge', low=2, high=32)
    margin_m: float = param(0.001, 'overlap the term tolerates: shallower contacts are left '
                            'to the cone field', unit='m', low=0.0, high=0.02)
    reach_m: float = param(0.005, 'pairs closer than this to overlapping at the start of a '
                           'round join its residuals', unit='m', low=0.0, high=0.05)


@dataclass(frozen=True)
class BallPairs:
    """The ball pairs of one round: ``ids`` (M, 2) int64, rows of ``candidates``."""

    ids: IntArray

    @property
    def n_residuals(self) -> int:
        """M."""
        return len(self.ids)


def sample_balls(pills: IntArray, pill_part: IntArray, wedges: IntArray, radii_m: FloatArray,
                 samples: int) -> tuple[FloatArray, FloatArray, IntArray]:
    """Interpolated balls of the sphere mesh.

    Parameters
    ----------
    pills : (Np, 2) int64
        Sphere pairs; ``pill_part`` (Np,) int64 their bones.
    wedges : (Nw, 3) int64
        Sphere triples of the palm (bone 0).
    radii_m : (S,) float64
        Sphere radii.
    samples : int
        Balls per pill and per side of a wedge's grid.

    Returns
    -------
    weights : (N, S) float64
        Ball centres as combinations of the sphere centres (rows sum to 1).
    radii_m : (N,) float64
    part : (N,) int64
    """
    n_spheres = len(radii_m)
    rows, parts = [], []
    t = np.linspace(0.0, 1.0, samples)
    for (a, b), part in zip(pills, pill_part):
        w = np.zeros((samples, n_spheres))
        w[:, a] += 1.0 - t
        w[:, b] += t
        rows.append(w)
        parts.append(np.full(samples, part))
    grid = [(i, j) for i in range(samples) for j in range(samples - i)]
    bary = np.array([(i, j, samples - 1 - i - j) for i, j in grid], float) / (samples - 1)
    for tri in wedges:
        w = np.zeros((len(bary), n_spheres))
        for k in range(3):
            w[:, tri[k]] += bary[:, k]
        rows.append(w)
        parts.append(np.zeros(len(bary), dtype=np.int64))
    weights = np.vstack(rows)
    # Balls shared by two elements (the corners of wedges and pills) appear once.
    weights, first = np.unique(weights, axis=0, return_index=True)
    part = np.concatenate(parts)[first]
    return weights, weights @ radii_m, part.astype(np.int64)


class VolumeCollisionEnergy:
    """Volume collision (see the module docstring); holds configuration and ball topology.

    Parameters
    ----------
    config : VolumeCollisionConfig
    weights : (N, S) float64
        Ball centres as combinations of the sphere centres (:func:`sample_balls`).
    radii_m : (N,) float64
        Ball radii.
    candidates : (K, 2) int64
        Ball pairs that may collide (non-adjacent parts, apart in the rest pose).
    """

    name = NAME

    def __init__(self, config: VolumeCollisionConfig, weights: FloatArray, radii_m: FloatArray,
                 candidates: IntArray) -> None:
        check_shape('radii_m', radii_m, (weights.shape[0],))
        check_shape('candidates', candidates, (None, 2))
        self.config = config
        self.weights = np.asarray(weights, np.float64)
        self.radii_m = np.asarray(radii_m, np.float64)
        self.candidates = np.asarray(candidates, np.int64)

    @classmethod
    def from_model(cls, config: VolumeCollisionConfig, model: HandModel) -> VolumeCollisionEnergy:
        """The term for a ``HandModel`` (its sphere mesh, adjacency and rest pose)."""
        pill_part = model.sphere_part[model.pills[:, 1]]
        weights, radii, part = sample_balls(model.pills, pill_part, model.wedges,
                                            model.sphere_radii_m, config.samples)
        rest = model.rest_bone_transforms[model.sphere_part]
        rest_centers = (np.einsum('sij,sj->si', rest[:, :3, :3], model.sphere_local_m)
                        + rest[:, :3, 3])
        return cls(config, weights, radii,
                   candidate_pairs(weights @ rest_centers, radii, part, model.adjacent_parts,
                                   config.margin_m))

    def overlaps(self, centers_m: FloatArray, pairs: IntArray) -> FloatArray:
        """``r_i + r_j - margin - d_ij`` (M,) float64 (m) of ball pairs (M, 2) at ball centres
        ``centers_m`` (N, 3)."""
        d = np.linalg.norm(centers_m[pairs[:, 0]] - centers_m[pairs[:, 1]], axis=1)
        return self.radii_m[pairs[:, 0]] + self.radii_m[pairs[:, 1]] - self.config.margin_m - d

    @property
    def weight(self) -> float:
        """Weight of the term's cost ``0.5 * weight * |r|^2``."""
        return self.config.weight

    def correspond(self, context: RoundContext) -> BallPairs:
        """Pairs within ``reach_m`` of overlapping at ``context.posed``."""
        return self.pairs_at(context.posed.sphere_centers_m)

    def pairs_at(self, sphere_centers_m: FloatArray, reach_m: float | None = None) -> BallPairs:
        """Pairs within ``reach_m`` (default: the config's) of overlapping, sphere centres
        (S, 3) float64 (m)."""
        reach_m = self.config.reach_m if reach_m is None else reach_m
        near = self.overlaps(self.weights @ sphere_centers_m, self.candidates)
        return BallPairs(self.candidates[near > -reach_m])

    def residuals(self, posed: PosedHand, pairs: BallPairs) -> FloatArray:
        """Residuals ``r (M,)`` (m), ``max(0, overlap)``."""
        centers = self.weights @ posed.sphere_centers_m
        return np.maximum(self.overlaps(centers, pairs.ids), 0.0)

    def jacobian_vertices(self, pairs: BallPairs) -> IntArray:
        """No mesh vertex: the rows read ``sphere_centers_jac`` only."""
        return np.zeros(0, dtype=np.int64)

    def linearize(self, posed: PosedHand, pairs: BallPairs) -> tuple[FloatArray, FloatArray]:
        """Residuals ``r (M,)`` (m) and analytic Jacobian ``J (M, P)`` (m per unit)."""
        if pairs.n_residuals == 0:
            return np.zeros(0), np.zeros((0, P))
        centers = self.weights @ posed.sphere_centers_m
        r = self.overlaps(centers, pairs.ids)
        active = np.flatnonzero(r > 0.0)
        jac = np.zeros((pairs.n_residuals, P))
        if active.size:
            a, b = pairs.ids[active, 0], pairs.ids[active, 1]
            delta = centers[a] - centers[b]                                    # (K, 3)
            u = delta / np.maximum(np.linalg.norm(delta, axis=1), 1e-12)[:, None]
            # d(c_a - c_b)/dtheta = (W_a - W_b) dS/dtheta, one (K, S) x (S, 3P) product.
            centers_jac = posed.sphere_centers_jac
            assert centers_jac is not None, 'posed without its Jacobian'
            d_delta = (self.weights[a] - self.weights[b]) @ centers_jac.reshape(-1, 3 * P)
            jac[active] = -np.einsum('kc,kcp->kp', u, d_delta.reshape(-1, 3, P))
        return np.maximum(r, 0.0), jac


def candidate_pairs(rest_centers_m: FloatArray, radii_m: FloatArray, part: IntArray,
                    adjacent_parts: BoolArray, margin_m: float) -> IntArray:
    """Ball pairs (K, 2) int64, ``i < j``, of different non-adjacent parts that do not overlap
    by more than ``margin_m`` at the rest centres (N, 3) float64."""
    i, j = np.triu_indices(len(radii_m), k=1)
    blocked = adjacent_parts[part[i], part[j]] | (part[i] == part[j])
    gap = np.linalg.norm(rest_centers_m[i] - rest_centers_m[j], axis=1) - radii_m[i] - radii_m[j]
    keep = ~blocked & (gap > -margin_m)
    return np.column_stack([i[keep], j[keep]]).astype(np.int64)
