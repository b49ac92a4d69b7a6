"""The energy terms of the tracker and their configs, in one place.

=====  ============  ==================================================  =====================
key    name          term                                                source
=====  ============  ==================================================  =====================
E      edges         model contours to oriented image edges (px)         Ballan et al. 2012
O      flow          points visible at t-1 carried by optical flow (px)  Ballan et al. 2012
S      salient       fingertips to detections, assignment re-solved (px) Ballan et al. 2012
C      collision     cone distance field between non-adjacent parts      Ballan, supplementary
C      volume        overlap of sphere-mesh balls, deep contacts (m)     htrack / hmodel
L      limits        limiting rotation R_L, finger planes (m)            convolution surfaces
Sil    silhouette    model silhouette points to camera rays (m)          convolution surfaces
T      temporal      constant-velocity prior on the 3D keypoints (m)     htrack
=====  ============  ==================================================  =====================

Each config has ``enabled`` and ``weight``; the ablation switches terms by ``enabled``. C is
two terms: the cone field for contact, and the volume term as a backstop where a part has sunk
too deep for the cone field (:mod:`hand_tracker_ros.energies.volume_collision`).
"""
from __future__ import annotations

from dataclasses import dataclass

from hand_tracker_ros.config import nested
from hand_tracker_ros.energies.collision import CollisionConfig, CollisionEnergy
from hand_tracker_ros.energies.edges import EdgeEnergy, EdgeEnergyConfig
from hand_tracker_ros.energies.flow import FlowEnergy, FlowEnergyConfig
from hand_tracker_ros.energies.joint_limits import JointLimitsConfig, JointLimitsEnergy
from hand_tracker_ros.energies.salient import SalientConfig, SalientEnergy
from hand_tracker_ros.energies.silhouette import SilhouetteConfig, SilhouetteEnergy
from hand_tracker_ros.energies.temporal import TemporalConfig, TemporalEnergy
from hand_tracker_ros.energies.volume_collision import (VolumeCollisionConfig,
                                                        VolumeCollisionEnergy)
from hand_tracker_ros.tracking.problem import Term
from hand_tracker_ros.model.hand import HandModel


@dataclass(frozen=True)
class TermsConfig:
    """Configs of every energy term."""

    edges: EdgeEnergyConfig = nested(EdgeEnergyConfig)
    flow: FlowEnergyConfig = nested(FlowEnergyConfig)
    salient: SalientConfig = nested(SalientConfig)
    collision: CollisionConfig = nested(CollisionConfig)
    volume: VolumeCollisionConfig = nested(VolumeCollisionConfig)
    limits: JointLimitsConfig = nested(JointLimitsConfig)
    silhouette: SilhouetteConfig = nested(SilhouetteConfig)
    temporal: TemporalConfig = nested(TemporalConfig)


_ENERGIES = (('edges', EdgeEnergy), ('flow', FlowEnergy), ('salient', SalientEnergy),
             ('collision', CollisionEnergy), ('volume', VolumeCollisionEnergy),
             ('limits', JointLimitsEnergy),
             ('silhouette', SilhouetteEnergy), ('temporal', TemporalEnergy))


def build_terms(config: TermsConfig, model: HandModel) -> list[Term]:
    """The enabled terms with their weights, built for ``model``."""
    terms = []
    for key, cls in _ENERGIES:
        term_config = getattr(config, key)
        if term_config.enabled and term_config.weight > 0.0:
            terms.append(Term(cls.from_model(term_config, model), term_config.weight))
    return terms
