"""Volume collision: ball sampling, zero on ground truth, Jacobian vs central differences,
and LM pushing deeply overlapping fingers apart (with the separation rounds)."""
from __future__ import annotations

import numpy as np
import pytest

from hand_tracker_ros.core.energy import Term
from hand_tracker_ros.energies.collision import CollisionConfig, CollisionEnergy
from hand_tracker_ros.energies.volume_collision import (
    VolumeCollisionConfig,
    VolumeCollisionEnergy,
    sample_balls,
)
from hand_tracker_ros.geometry.triangle_pairs import (
    face_parts,
    intersecting_pairs,
    max_interpenetration_m,
)
from hand_tracker_ros.model.layout import PARAM_NAMES
from hand_tracker_ros.optim.lm import LMConfig
from hand_tracker_ros.synthetic.motions import trajectory
from hand_tracker_ros.tracking.separation import SeparationConfig, Separator


@pytest.fixture(scope='module')
def energy(hand_model):
    return VolumeCollisionEnergy.from_model(VolumeCollisionConfig(), hand_model)


def _crossed(hand_model, spread: float) -> np.ndarray:
    """Index and middle finger abducted ``spread`` rad each towards the other."""
    theta = hand_model.neutral_theta()
    theta[PARAM_NAMES.index('index_mcp_abd')] -= spread
    theta[PARAM_NAMES.index('middle_mcp_abd')] += spread
    return theta


def _depth_mm(hand_model, theta) -> float:
    posed = hand_model.pose(theta, jacobian=False)
    return 1e3 * max_interpenetration_m(posed.vertices_m, hand_model.faces,
                                        face_parts(hand_model.faces, hand_model.vertex_part),
                                        hand_model.adjacent_parts)


def test_balls_interpolate_the_spheres(hand_model) -> None:
    pill_part = hand_model.sphere_part[hand_model.pills[:, 1]]
    weights, radii, part = sample_balls(hand_model.pills, pill_part, hand_model.wedges,
                                        hand_model.sphere_radii_m, 4)
    assert np.allclose(weights.sum(axis=1), 1.0) and np.all(weights >= 0.0)
    assert len(np.unique(weights, axis=0)) == len(weights)       # shared corners once
    r = hand_model.sphere_radii_m
    assert r.min() - 1e-12 <= radii.min() and radii.max() <= r.max() + 1e-12
    # 15 pills x 4 balls, minus the ends two pills share, plus the palm grid
    assert set(np.unique(part)) == set(range(16))


def test_zero_on_the_ground_truth_of_the_benchmark_motions(hand_model, energy) -> None:
    pairs = energy.candidates
    worst = -np.inf
    for motion in ('grasp', 'tapping', 'random'):
        for theta in trajectory(motion, 150, 30.0, seed=0):
            centers = energy.weights @ hand_model.pose(theta, jacobian=False).sphere_centers_m
            worst = max(worst, float(energy.overlaps(centers, pairs).max()))
    assert worst < 0.0


def test_crossed_fingers_overlap_and_the_jacobian_matches_central_differences(
        hand_model, energy) -> None:
    theta = _crossed(hand_model, 0.3)
    posed = hand_model.pose(theta)
    pairs = energy.correspond(type('Ctx', (), {'posed': posed})())
    r, J = energy.linearize(posed, pairs)
    assert np.all(energy.residuals(posed, pairs) == r)
    assert (r > 0.0).sum() >= 3 and r.max() > 3e-3          # several balls, > 3 mm deep
    step = 1e-6
    numeric = np.empty_like(J)
    for k in range(theta.size):
        e = np.zeros_like(theta)
        e[k] = step
        numeric[:, k] = (energy.residuals(hand_model.pose(theta + e, jacobian=False), pairs)
                         - energy.residuals(hand_model.pose(theta - e, jacobian=False),
                                            pairs)) / (2 * step)
    active = r > 1e-5                                     # away from the hinge at 0
    np.testing.assert_allclose(J[active], numeric[active], atol=1e-7, rtol=1e-5)
    assert np.all(J[r == 0.0] == 0.0)


def test_separation_rounds_push_crossed_fingers_apart(hand_model) -> None:
    theta = _crossed(hand_model, 0.2)
    assert _depth_mm(hand_model, theta) > 5.0
    terms = [Term(CollisionEnergy.from_model(CollisionConfig(), hand_model), 3e3),
             Term(VolumeCollisionEnergy.from_model(VolumeCollisionConfig(), hand_model), 1e10)]
    # The tracker's LM settings: separation.iterations, capped by lm.max_iterations (10).
    separator = Separator(hand_model, terms, SeparationConfig(rounds=5), LMConfig())
    result = separator.separate(theta, None)
    assert 1 <= result.rounds <= 5
    assert _depth_mm(hand_model, result.theta) < 0.5
    assert len(intersecting_pairs(result.posed.vertices_m, hand_model.faces,
                                  face_parts(hand_model.faces, hand_model.vertex_part),
                                  hand_model.adjacent_parts)) == 0
    # The anchor keeps the hand in place: only the two crossed fingers move.
    before = hand_model.pose(theta, jacobian=False).keypoints_m
    moved_mm = 1e3 * np.linalg.norm(
        hand_model.pose(result.theta, jacobian=False).keypoints_m - before, axis=1)
    assert moved_mm.max() < 15.0
    assert np.all(moved_mm[:5] < 1.0)   # wrist and thumb keypoints
    untouched = separator.separate(hand_model.neutral_theta(), None)
    assert untouched.rounds == 0 and np.array_equal(untouched.theta,
                                                    hand_model.neutral_theta())


# A tracked pose of the LO+EC row on the benchmark's random sequence (frame 26, seed 0): a
# ring finger 1.1 mm inside its neighbour, which rounds of 4 LM iterations left in place.
_SHALLOW_CONTACT = np.array([
    0.028311218345815833, -0.10714601705201893, 0.0029145113514064047, -0.009211085529802654,
    -1.6743564119041223, 0.17276372405090673, 0.746791697093688, 0.13238876500912788,
    -0.07199199402443275, 1.1405731214035162, -0.4935988842750075, 0.17805295355456247,
    1.3033231998851513, 1.548223430078786, -0.11776134868523185, 0.18750544900129174,
    1.8920471388306126, 1.5707963267948966, -0.19005374159047753, 0.20691299469555088,
    1.4939291095895548, 0.9952774901983716, 0.4283593751256676, 0.14637960398996241,
    1.1718366377921905, 1.5707963267948966])


def test_separation_rounds_have_iterations_enough_for_the_stiff_terms(hand_model) -> None:
    assert _depth_mm(hand_model, _SHALLOW_CONTACT) > 1.0
    terms = [Term(CollisionEnergy.from_model(CollisionConfig(), hand_model), 3e3),
             Term(VolumeCollisionEnergy.from_model(VolumeCollisionConfig(), hand_model), 1e10)]
    depth = {}
    for iterations in (4, SeparationConfig().iterations):
        separator = Separator(hand_model, terms, SeparationConfig(iterations=iterations),
                              LMConfig())
        depth[iterations] = _depth_mm(hand_model,
                                      separator.separate(_SHALLOW_CONTACT, None).theta)
    # LM rejects its first, lightly damped steps on these residuals: 4 per round never move.
    assert depth[4] > 1.0
    assert depth[SeparationConfig().iterations] < 0.5
