"""Tests of the salient-point term S: gated assignment, Jacobian, labels and a fit."""
from __future__ import annotations

import numpy as np
import pytest

from hand_tracker_ros.config import from_mapping
from hand_tracker_ros.core.context import RoundContext
from hand_tracker_ros.core.observations import CameraObservation, FrameObservations
from hand_tracker_ros.core.views import model_views
from hand_tracker_ros.energies.salient import (
    SalientConfig,
    SalientCorrespondences,
    SalientEnergy,
    assign_detections,
)
from hand_tracker_ros.errors import ConfigError
from hand_tracker_ros.geometry.rig import CameraRig
from hand_tracker_ros.model.layout import PARAM_NAMES, P
from hand_tracker_ros.optim.lm import LMConfig, levenberg_marquardt
from hand_tracker_ros.render.contours import MeshEdges
from hand_tracker_ros.render.fingertips import cap_slack_m, visible_fingertips
from hand_tracker_ros.vision.detections import SalientDetections

TIPS = np.array([[50.0, 50.0], [80.0, 40.0], [110.0, 38.0], [140.0, 45.0], [165.0, 60.0]])


def test_assignment_labels_three_tips_and_leaves_a_distractor():
    detections = np.array([TIPS[3] + (2.0, -1.0), [300.0, 200.0], TIPS[0] + (-3.0, 2.0),
                           TIPS[1] + (1.0, 4.0)])
    np.testing.assert_array_equal(assign_detections(TIPS, detections, 12.0), [3, -1, 0, 1])


def test_assignment_goes_to_the_nearer_tip_and_respects_the_gate():
    between = TIPS[1] + 0.4 * (TIPS[2] - TIPS[1])
    np.testing.assert_array_equal(assign_detections(TIPS, between[None], 30.0), [1])
    # 12.5 px from the middle tip and farther from the others: beyond a 12 px gate.
    far = TIPS[2] + (0.0, -12.5)
    np.testing.assert_array_equal(assign_detections(TIPS, far[None], 12.0), [-1])
    np.testing.assert_array_equal(assign_detections(TIPS, far[None], 13.0), [2])


def test_assignment_resolves_a_conflict_jointly():
    """Two detections nearest the same tip: the joint optimum gives one to the neighbour."""
    tips = np.array([[0.0, 0.0], [10.0, 0.0]])
    detections = np.array([[1.0, 0.0], [4.0, 0.0]])
    # Greedy nearest-tip labelling would give both to tip 0; the optimum is 1 + 6 = 7 px.
    np.testing.assert_array_equal(assign_detections(tips, detections, 8.0), [0, 1])
    # With a 5 px gate the second pair (6 px) is forbidden: it stays unassigned.
    np.testing.assert_array_equal(assign_detections(tips, detections, 5.0), [0, -1])


def test_assignment_is_invariant_to_the_detection_order():
    rng = np.random.default_rng(3)
    detections = np.vstack([TIPS + rng.normal(0.0, 3.0, TIPS.shape),
                            rng.uniform(0.0, 320.0, (4, 2))])
    reference = assign_detections(TIPS, detections, 12.0)
    assert np.count_nonzero(reference >= 0) >= 5
    for _ in range(5):
        order = rng.permutation(len(detections))
        np.testing.assert_array_equal(assign_detections(TIPS, detections[order], 12.0),
                                      reference[order])


def test_assignment_edge_cases():
    assert assign_detections(TIPS, np.zeros((0, 2)), 12.0).shape == (0,)
    np.testing.assert_array_equal(assign_detections(np.zeros((0, 2)), TIPS, 12.0), [-1] * 5)
    np.testing.assert_array_equal(assign_detections(TIPS, np.array([[-500.0, 1e4]]), 12.0),
                                  [-1])


class Scene:
    """The hand before two 320x240 cameras, detections at the true projected fingertips
    that show."""

    def __init__(self, model: object) -> None:
        self.model = model
        self.rig = CameraRig.ring(2, 320, 240, radius_m=0.4)
        self.edges = MeshEdges.from_faces(model.faces)
        centre = -model.pose(model.neutral_theta(), jacobian=False).vertices_m.mean(axis=0)
        # Ring and pinky curled into the palm, so that a tip is hidden in a view.
        theta = model.neutral_theta(tuple(centre))
        curled = [PARAM_NAMES.index(f'{finger}_{joint}_flex') for finger in ('ring', 'pinky')
                  for joint in ('mcp', 'pip', 'dip')]
        theta[curled] = model.upper[curled]
        self.theta_true = theta
        posed = model.pose(self.theta_true, jacobian=False)
        self.truth_views = model_views(posed, self.edges, tuple(self.rig))
        self.tips_uv = [view.raster.uv_px[model.fingertip_vertex_ids]
                        for view in self.truth_views]
        self.tips_visible = [visible_fingertips(view.raster, model.fingertip_vertex_ids,
                                                cap_slack_m(model))
                             for view in self.truth_views]

    def detections(self, rng: np.random.Generator) -> list[SalientDetections]:
        """Visible true tips + 0.5 px noise, score 0.9, plus one far distractor per camera."""
        out = []
        for uv, visible in zip(self.tips_uv, self.tips_visible):
            pts = np.vstack([uv[visible] + rng.normal(0.0, 0.5, (visible.sum(), 2)),
                             [[10.0, 10.0]]])
            score = np.r_[np.full(visible.sum(), 0.9), 0.95]
            out.append(SalientDetections(pts, score))
        return out

    def context(self, theta: np.ndarray, detections: list[SalientDetections]) -> RoundContext:
        posed = self.model.pose(theta)
        views = model_views(posed, self.edges, tuple(self.rig))
        # The salient term reads only the camera and the detections of an observation.
        cams = tuple(CameraObservation(camera, None, tips)
                     for camera, tips in zip(self.rig, detections))
        return RoundContext(posed, views, FrameObservations(0, cams), None)


def _offset(theta: np.ndarray, changes: dict[str, float]) -> np.ndarray:
    out = theta.copy()
    for name, value in changes.items():
        out[PARAM_NAMES.index(name)] += value
    return out


# A pose error that keeps every projected tip within the 12 px gate of its detection.
_ERROR = {'hand_tx': 0.004, 'hand_ty': -0.003, 'hand_rz': 0.03, 'index_mcp_flex': 0.1,
          'ring_mcp_abd': -0.05, 'thumb_cmc_flex': 0.08}


@pytest.fixture(scope='module')
def scene(hand_model) -> Scene:
    return Scene(hand_model)


@pytest.fixture(scope='module')
def energy(hand_model) -> SalientEnergy:
    return SalientEnergy.from_model(SalientConfig(), hand_model)


def test_correspond_labels_the_fingers_and_ignores_the_distractor(scene, energy):
    rng = np.random.default_rng(0)
    corr = energy.correspond(scene.context(_offset(scene.theta_true, _ERROR),
                                           scene.detections(rng)))
    for labels, visible in zip(corr.labels, scene.tips_visible):
        np.testing.assert_array_equal(labels, np.r_[np.flatnonzero(visible), -1])
    assert corr.n_residuals == 2 * sum(int(v.sum()) for v in scene.tips_visible)
    assert not all(v.all() for v in scene.tips_visible)   # the scene has a hidden tip


def test_labels_follow_a_permutation_of_the_detections(scene, energy):
    rng = np.random.default_rng(1)
    base = scene.detections(rng)
    reference = energy.correspond(scene.context(scene.theta_true, base)).labels
    orders = [rng.permutation(len(d.score)) for d in base]
    shuffled = [SalientDetections(d.uv_px[o], d.score[o]) for d, o in zip(base, orders)]
    labels = energy.correspond(scene.context(scene.theta_true, shuffled)).labels
    for ref, new, order in zip(reference, labels, orders):
        np.testing.assert_array_equal(new, ref[order])


def test_low_scores_and_hidden_tips_are_not_assigned(scene, energy, hand_model):
    hidden = [np.flatnonzero(~v) for v in scene.tips_visible]
    detections = [SalientDetections(np.vstack([uv[h], uv[:1] + 1.0]),
                                    np.r_[np.full(len(h), 0.9), 0.2])
                  for uv, h in zip(scene.tips_uv, hidden)]
    corr = energy.correspond(scene.context(scene.theta_true, detections))
    for labels, h in zip(corr.labels, hidden):
        # A hidden tip's detection may only go to a visible tip within the gate.
        assert not np.isin(labels, h).any()
        assert labels[-1] == -1
    r, J = energy.linearize(hand_model.pose(scene.theta_true), corr)
    assert np.all(np.isfinite(r)) and J.shape == (r.size, P)


def test_no_detections_gives_no_rows(scene, energy, hand_model):
    context = scene.context(scene.theta_true, [SalientDetections.empty()] * 2)
    corr = energy.correspond(context)
    assert isinstance(corr, SalientCorrespondences) and corr.n_residuals == 0
    assert [lab.shape for lab in corr.labels] == [(0,), (0,)]
    r, J = energy.linearize(context.posed, corr)
    assert r.shape == (0,) and J.shape == (0, P)
    assert energy.residuals(context.posed, corr).shape == (0,)


def test_gate_scales_with_the_image_width(energy, hand_model):
    assert energy.gate_px(320) == pytest.approx(12.0)
    assert energy.gate_px(640) == pytest.approx(24.0)
    config = from_mapping(SalientConfig, {'gate_px': 30.0, 'reference_width_px': 1000})
    assert SalientEnergy.from_model(config, hand_model).gate_px(320) == pytest.approx(9.6)
    with pytest.raises(ConfigError, match='min_score'):
        from_mapping(SalientConfig, {'min_score': 1.5})


def test_residuals_are_score_weighted_reprojection_errors(scene, energy, hand_model):
    detections = [SalientDetections(uv + 2.0, np.full(5, 0.64)) for uv in scene.tips_uv]
    corr = energy.correspond(scene.context(scene.theta_true, detections))
    r = energy.residuals(hand_model.pose(scene.theta_true, jacobian=False), corr)
    np.testing.assert_allclose(r, -0.8 * 2.0, atol=1e-9)


def test_jacobian_matches_central_differences(scene, energy, hand_model):
    rng = np.random.default_rng(4)
    theta0 = _offset(scene.theta_true, _ERROR)
    corr = energy.correspond(scene.context(theta0, scene.detections(rng)))
    assert corr.n_residuals >= 14
    r, J = energy.linearize(hand_model.pose(theta0), corr)
    numeric = np.empty_like(J)
    for p in range(P):
        step = np.zeros(P)
        step[p] = 1e-6
        plus = energy.residuals(hand_model.pose(theta0 + step, jacobian=False), corr)
        minus = energy.residuals(hand_model.pose(theta0 - step, jacobian=False), corr)
        numeric[:, p] = (plus - minus) / 2e-6
    np.testing.assert_allclose(J, numeric, rtol=1e-5, atol=1e-5 * np.abs(J).max())


def test_lm_with_reassignment_recovers_the_fingertips(scene, energy, hand_model):
    rng = np.random.default_rng(5)
    detections = scene.detections(rng)
    truth = hand_model.pose(scene.theta_true, jacobian=False).fingertips_m
    theta = _offset(scene.theta_true, _ERROR)

    def tip_error_mm(th: np.ndarray) -> float:
        tips = hand_model.pose(th, jacobian=False).fingertips_m
        return 1e3 * float(np.mean(np.linalg.norm(tips - truth, axis=1)))

    start = tip_error_mm(theta)
    for _ in range(3):
        corr = energy.correspond(scene.context(theta, detections))

        def fun(th, jacobian, corr=corr):
            posed = hand_model.pose(th, jacobian=jacobian)
            if jacobian:
                return energy.linearize(posed, corr)
            return energy.residuals(posed, corr), None

        theta = levenberg_marquardt(fun, theta, hand_model.lower, hand_model.upper,
                                    config=LMConfig(max_iterations=30)).x
    assert start > 5.0
    assert tip_error_mm(theta) < 0.3 * start
