r"""Separation rounds: push apart the parts the fitted estimate still has inside each other.

The image terms can hold two fingers inside each other against the collision terms: when the
tracker has drifted, edges of one finger are matched to the other's, and the cone field's
push (a residual of at most about 1 per constraint within a cone height of the surface,
:mod:`hand_tracker_ros.energies.cone_field`) loses against a few hundred pulling edge
residuals (measured on the ablation rows without the silhouette term:
2-8 mm deep frames with the collision term on). After the data rounds, while non-adjacent parts
of the estimate ``theta_0`` intersect, each separation round minimises the collision terms
alone against an anchor that keeps the hand where the data put it::

    F(theta) = 0.5 w_C |r_C(theta)|^2 + 0.5 w_V |r_V(theta)|^2
               + 0.5 w_A |k(theta) - k(theta_0)|^2

(``r_C`` the cone field, ``r_V`` the volume term over all candidate ball pairs, ``k`` the 21
keypoints), i.e. the nearest pose without the contact, in the metric of keypoint motion: a
projection of the estimate onto the physically plausible poses, in the spirit of the physics
step Tzionas et al. (IJCV 2016) add to Ballan's tracker. The anchor weight ``w_A`` is low
(1e5: 1 cm of keypoint motion costs 5, one cone constraint a cone height deep 1.5e3), so the
collision terms win wherever they are active, and the anchor only chooses among the poses that
resolve them. Constraints of the frame's earlier rounds are kept (see
:class:`~hand_tracker_ros.core.context.RoundContext`), so a round cannot slide a finger back
into a contact an earlier one resolved.

References: docs/references.md.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.config import param
from hand_tracker_ros.core.context import CollisionPairs, RoundContext
from hand_tracker_ros.core.energy import Term
from hand_tracker_ros.core.observations import FrameObservations
from hand_tracker_ros.energies.collision import CollisionEnergy
from hand_tracker_ros.energies.registry import SEPARATION_TERMS
from hand_tracker_ros.energies.temporal import TemporalConfig, TemporalEnergy, TemporalTarget
from hand_tracker_ros.energies.volume_collision import VolumeCollisionEnergy
from hand_tracker_ros.model.hand import HandModel, PosedHand
from hand_tracker_ros.model.layout import Layout
from hand_tracker_ros.optim.lm import FitStatus, LMConfig, levenberg_marquardt
from hand_tracker_ros.tracking.problem import Problem


@dataclass(frozen=True)
class SeparationConfig:
    """Separation rounds after the data rounds of a frame."""

    rounds: int = param(3, 'separation rounds at most, each while non-adjacent parts of the '
                        'estimate intersect (0: off)', low=0, high=20)
    iterations: int = param(10, 'LM iterations per separation round (Ballan: 10). Not the data '
                            "rounds' count: the stiff collision residuals make LM reject its "
                            'first, lightly damped steps, and a round of 4 iterations could end '
                            'where it started', low=1, high=100)
    anchor_weight: float = param(1e5, 'weight of the keypoints staying where the data rounds '
                                 'put them (cost = 0.5 * weight * |dk|^2, dk in m)', low=0.0,
                                 high=1e12)


@dataclass(frozen=True, eq=False)
class SeparationResult:
    """Outcome of :meth:`Separator.separate`."""

    theta: FloatArray                  # (P,)
    posed: PosedHand                   # the hand posed at ``theta`` (no Jacobian)
    rounds: int                        # separation rounds run
    iterations: int                    # LM iterations over them
    statuses: tuple[FitStatus, ...] = ()  # why each round's LM call stopped


class Separator:
    """Runs separation rounds with the tracker's collision terms (see the module docstring).

    Parameters
    ----------
    model : HandModel
    terms : sequence of Term
        The tracker's enabled terms; the ones named in ``SEPARATION_TERMS`` are used.
    config : SeparationConfig
    lm : LMConfig
        Settings of each round's Levenberg-Marquardt call; it runs ``config.iterations``,
        capped by ``lm.max_iterations``.
    """

    def __init__(self, model: HandModel, terms: Sequence[Term], config: SeparationConfig,
                 lm: LMConfig) -> None:
        self.model = model
        self.config = config
        self.lm = dataclasses.replace(lm, max_iterations=min(config.iterations,
                                                             lm.max_iterations))
        self._terms = [t for t in terms if t.name in SEPARATION_TERMS]
        self._collision = next((t.energy for t in self._terms
                                if isinstance(t.energy, CollisionEnergy)), None)
        anchor = TemporalEnergy(TemporalConfig(mode='damping'), model.rest,
                                model.keypoint_local_m)
        self._anchor = Term(anchor, config.anchor_weight)

    def separate(self, theta: FloatArray, collisions: CollisionPairs | None
                 ) -> SeparationResult:
        """Separation rounds from ``theta`` (P,), keeping the frame's earlier ``collisions``."""
        posed = self.model.pose(theta, jacobian=False)
        anchor = TemporalTarget(posed.keypoints_m)
        n_rounds = iterations = 0
        statuses: list[FitStatus] = []
        if self._collision is None:
            return SeparationResult(theta, posed, n_rounds, iterations, tuple(statuses))
        for _ in range(self.config.rounds):
            context = RoundContext(posed, (), FrameObservations(0, ()), None, collisions)
            collisions = self._collision.correspond(context)
            if len(collisions.face_pairs) == 0:     # no non-adjacent parts intersect now
                break
            # The volume term over every candidate ball pair: no new contact hides beyond a
            # reach.
            correspondences = [t.energy.pairs_at(posed.sphere_centers_m, reach_m=np.inf)
                               if isinstance(t.energy, VolumeCollisionEnergy) else collisions
                               for t in self._terms]
            problem = Problem(self.model, [*self._terms, self._anchor])
            result = levenberg_marquardt(problem.function([*correspondences, anchor]), theta,
                                         self.model.lower, self.model.upper, config=self.lm,
                                         angular=Layout.revolute)
            theta = result.x
            posed = self.model.pose(theta, jacobian=False)
            n_rounds += 1
            iterations += result.n_iterations
            statuses.append(result.status)
        return SeparationResult(theta, posed, n_rounds, iterations, tuple(statuses))
