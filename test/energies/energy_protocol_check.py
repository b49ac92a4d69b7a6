"""Static check, read by mypy (mypy.ini lists this file): every term class implements
``Energy[C]`` with its own correspondence type ``C``. Not a pytest module."""
from __future__ import annotations

from hand_tracker_ros.core.context import CollisionPairs
from hand_tracker_ros.core.energy import Energy
from hand_tracker_ros.energies.collision import CollisionEnergy
from hand_tracker_ros.energies.edges import EdgeCorrespondences, EdgeEnergy
from hand_tracker_ros.energies.flow import FlowCorrespondences, FlowEnergy
from hand_tracker_ros.energies.joint_limits import JointLimitsEnergy, LimitTargets
from hand_tracker_ros.energies.salient import SalientCorrespondences, SalientEnergy
from hand_tracker_ros.energies.silhouette import SilhouetteCorrespondences, SilhouetteEnergy
from hand_tracker_ros.energies.temporal import TemporalEnergy, TemporalTarget
from hand_tracker_ros.energies.volume_collision import BallPairs, VolumeCollisionEnergy


def every_term_is_an_energy(
        collision: CollisionEnergy, edges: EdgeEnergy, flow: FlowEnergy,
        limits: JointLimitsEnergy, salient: SalientEnergy, silhouette: SilhouetteEnergy,
        temporal: TemporalEnergy, volume: VolumeCollisionEnergy,
) -> tuple[Energy[CollisionPairs], Energy[EdgeCorrespondences], Energy[FlowCorrespondences],
           Energy[LimitTargets], Energy[SalientCorrespondences],
           Energy[SilhouetteCorrespondences], Energy[TemporalTarget], Energy[BallPairs]]:
    return collision, edges, flow, limits, salient, silhouette, temporal, volume
