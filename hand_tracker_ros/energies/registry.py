"""The energy terms of the tracker, in one table: every other list of terms derives from it.

=====  ============  ==================================================  ======================
key    name          term                                                where it is documented
=====  ============  ==================================================  ======================
E      edges         model contours to oriented image edges (px)         :mod:`.edges`
O      flow          points visible at t-1 carried by optical flow (px)  :mod:`.flow`
S      salient       fingertips to detections, assignment re-solved (px) :mod:`.salient`
C      collision     cone distance field between non-adjacent parts      :mod:`.collision`
C      volume        overlap of sphere-mesh balls, deep contacts (m)     :mod:`.volume_collision`
L      limits        limiting rotation R_L, finger planes (m)            :mod:`.joint_limits`
Sil    silhouette    model silhouette points to camera rays (m)          :mod:`.silhouette`
T      temporal      constant-velocity prior on the 3D keypoints (m)     :mod:`.temporal`
=====  ============  ==================================================  ======================

:data:`TERMS` is the table; the configuration (:class:`TermsConfig`, whose fields the tests
check against it), the terms the tracker builds (:func:`build_terms`), the terms the
separation rounds use (:data:`SEPARATION_TERMS`) and the ablation presets
(:func:`ablation_terms`, ``evaluation/presets.py``) derive from it. Each config has ``enabled``
and ``weight``; the ablation switches terms by ``enabled``. C is two terms: the cone field for
contact, and the volume term as a backstop where a part has sunk too deep for the cone field
(:mod:`hand_tracker_ros.energies.volume_collision`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from hand_tracker_ros.config import nested
from hand_tracker_ros.core.energy import Term
from hand_tracker_ros.energies.collision import CollisionConfig, CollisionEnergy
from hand_tracker_ros.energies.edges import EdgeEnergy, EdgeEnergyConfig
from hand_tracker_ros.energies.flow import FlowEnergy, FlowEnergyConfig
from hand_tracker_ros.energies.joint_limits import JointLimitsConfig, JointLimitsEnergy
from hand_tracker_ros.energies.salient import SalientConfig, SalientEnergy
from hand_tracker_ros.energies.silhouette import SilhouetteConfig, SilhouetteEnergy
from hand_tracker_ros.energies.temporal import TemporalConfig, TemporalEnergy
from hand_tracker_ros.energies.volume_collision import VolumeCollisionConfig, VolumeCollisionEnergy
from hand_tracker_ros.model.hand import HandModel


@dataclass(frozen=True)
class TermSpec:
    """One row of the table."""

    key: str                  # letter of the ablation rows (README, ``evaluation/presets.py``)
    energy: Any               # the term's class: ``name``, ``from_model(config, model)``
    config: type              # its config dataclass
    separation: bool = False  # also minimised by the separation rounds (``tracking/separation``)
    size: bool = False        # sees the hand's size in the images (``calibration/``, the online
    #                           scale of ``tracking/scale.py``); the others are priors on the pose

    @property
    def name(self) -> str:
        """The term's name: its config key, its key in cost tables."""
        return str(self.energy.name)


TERMS: tuple[TermSpec, ...] = (
    TermSpec('E', EdgeEnergy, EdgeEnergyConfig, size=True),
    TermSpec('O', FlowEnergy, FlowEnergyConfig),
    TermSpec('S', SalientEnergy, SalientConfig, size=True),
    TermSpec('C', CollisionEnergy, CollisionConfig, separation=True),
    TermSpec('C', VolumeCollisionEnergy, VolumeCollisionConfig, separation=True),
    TermSpec('L', JointLimitsEnergy, JointLimitsConfig),
    TermSpec('Sil', SilhouetteEnergy, SilhouetteConfig, size=True),
    TermSpec('T', TemporalEnergy, TemporalConfig),
)
NAMES: tuple[str, ...] = tuple(t.name for t in TERMS)
SEPARATION_TERMS: tuple[str, ...] = tuple(t.name for t in TERMS if t.separation)
SIZE_TERMS: tuple[str, ...] = tuple(t.name for t in TERMS if t.size)
#: The term of the local optimizer itself, in every ablation row (the temporal prior).
ALWAYS_IN_ABLATION = 'T'


@dataclass(frozen=True)
class TermsConfig:
    """Configs of every energy term: one field per row of :data:`TERMS`, in its order."""

    edges: EdgeEnergyConfig = nested(EdgeEnergyConfig)
    flow: FlowEnergyConfig = nested(FlowEnergyConfig)
    salient: SalientConfig = nested(SalientConfig)
    collision: CollisionConfig = nested(CollisionConfig)
    volume: VolumeCollisionConfig = nested(VolumeCollisionConfig)
    limits: JointLimitsConfig = nested(JointLimitsConfig)
    silhouette: SilhouetteConfig = nested(SilhouetteConfig)
    temporal: TemporalConfig = nested(TemporalConfig)


def ablation_terms(letters: str) -> tuple[str, ...]:
    """Names of the terms of ablation row ``LO+<letters>`` (single-letter keys, e.g. ``ECOS``),
    with the temporal prior every row has."""
    keys = set(letters) | {ALWAYS_IN_ABLATION}
    return tuple(t.name for t in TERMS if t.key in keys)


def build_terms(config: TermsConfig, model: HandModel) -> list[Term]:
    """The enabled terms with their weights, built for ``model``."""
    terms = []
    for spec in TERMS:
        term_config = getattr(config, spec.name)
        if term_config.enabled and term_config.weight > 0.0:
            terms.append(Term(spec.energy.from_model(term_config, model), term_config.weight))
    return terms


def size_terms(config: TermsConfig, model: HandModel) -> list[Term]:
    """The enabled terms of :data:`SIZE_TERMS` with their weights, built for ``model``."""
    return [t for t in build_terms(config, model) if t.name in SIZE_TERMS]
