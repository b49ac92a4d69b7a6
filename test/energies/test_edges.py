"""Edge term E: 1D oriented edge search, outlier rejection, Jacobian, fitting on rendered data."""
from __future__ import annotations

import math

import numpy as np
import pytest

from hand_tracker_ros.core.context import RoundContext
from hand_tracker_ros.core.observations import CameraObservation, FrameObservations
from hand_tracker_ros.core.views import model_views
from hand_tracker_ros.energies.edges import (
    EdgeEnergy,
    EdgeEnergyConfig,
    reject_outliers,
    search_edges,
)
from hand_tracker_ros.errors import ShapeError
from hand_tracker_ros.geometry.rig import CameraRig
from hand_tracker_ros.optim.lm import LMConfig, levenberg_marquardt
from hand_tracker_ros.render.background import make_background
from hand_tracker_ros.render.contours import MeshEdges
from hand_tracker_ros.render.rasterizer import render
from hand_tracker_ros.render.shading import render_rgb
from hand_tracker_ros.vision.detections import SalientDetections
from hand_tracker_ros.vision.edges import EdgeMap
from hand_tracker_ros.vision.features import FeatureExtractor, FeaturesConfig
from hand_tracker_ros.vision.mask import MaskConfig

_TRANSLATION = (0.0, -0.08, -0.02)
# Tau small enough that the first LM steps are not over-damped on the finger columns.
_LM = LMConfig(max_iterations=5, tau=1e-9)


def _edge_map(edges: np.ndarray, orientation: float, offset: tuple[int, int] = (0, 0)
              ) -> EdgeMap:
    """An EdgeMap with one gradient direction everywhere."""
    return EdgeMap(edges=edges, orientation_rad=np.full(edges.shape, orientation, np.float32),
                   offset_uv_px=offset)


def test_search_finds_first_compatible_edge_and_the_nearer_side() -> None:
    edges = np.zeros((40, 80), bool)
    edges[:, 50] = True
    edges[:, 40] = True
    emap = _edge_map(edges, 0.0)
    uv = np.array([[44.3, 20.0], [47.0, 5.0], [30.0, 20.0], [44.3, 20.0]])
    normals = np.array([[1.0, 0.0], [-1.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    target, found = search_edges(emap, uv, normals, 15.0, 0.7)
    np.testing.assert_array_equal(found, [True, True, True, False])
    np.testing.assert_array_equal(target[:3], [[40, 20], [50, 5], [40, 20]])


def test_search_respects_range_orientation_and_roi_offset() -> None:
    edges = np.zeros((30, 30), bool)
    edges[:, 20] = True
    offset = (100, 50)
    uv = np.array([[110.0, 60.0], [104.0, 60.0]])
    normals = np.array([[1.0, 0.0], [1.0, 0.0]])
    target, found = search_edges(_edge_map(edges, math.pi, offset), uv, normals, 15.0, 0.7)
    np.testing.assert_array_equal(found, [True, False])   # the second is 16 px away
    np.testing.assert_array_equal(target[0], [120, 60])   # polarity ignored (gradient = pi)
    _, found = search_edges(_edge_map(edges, math.radians(60), offset), uv, normals, 15, 0.7)
    assert not found.any()                                # |cos 60 deg| = 0.5 < 0.7


def test_search_does_not_step_over_a_thin_diagonal_edge() -> None:
    # An 8-connected anti-diagonal line u + v = 41 crossed at 45 degrees from every start.
    edges = np.zeros((60, 60), bool)
    for u in range(60):
        if 0 <= 41 - u < 60:
            edges[41 - u, u] = True
    n = np.array([[1.0, 1.0]]) / math.sqrt(2.0)
    starts = np.array([[10.0 + 0.13 * k, 10.0 + 0.07 * k] for k in range(40)])
    _, found = search_edges(_edge_map(edges, math.pi / 4), starts, np.repeat(n, 40, 0), 20, 0.9)
    assert found.all()


def test_reject_outliers_per_bone_with_floor_and_minimum_count() -> None:
    rng = np.random.default_rng(3)
    d = np.concatenate([rng.uniform(0.5, 1.5, 30), [9.0], rng.uniform(0, 1, 5), [9.0]])
    part = np.array([1] * 31 + [2] * 6)
    keep = reject_outliers(d, part, floor_px=3.0, factor=2.0, min_matches=20)
    assert not keep[30] and keep[:30].all()   # bone 1: 31 matches, mean < 3 -> limit 6 px
    assert keep[31:].all()                    # bone 2: too few matches to test
    assert reject_outliers(np.zeros(0), np.zeros(0, np.int64), 3.0, 2.0, 20).shape == (0,)


# --- rendered data ------------------------------------------------------------------------

@pytest.fixture(scope='module')
def scene(hand_model):
    rig = CameraRig.ring(2, 320, 240)
    edges = MeshEdges.from_faces(hand_model.faces)
    truth = hand_model.neutral_theta(_TRANSLATION)
    posed = hand_model.pose(truth, jacobian=False)
    cams = []
    for i, cam in enumerate(rig):
        raster = render(cam, posed.vertices_m, hand_model.faces)
        image = render_rgb(cam, posed.vertices_m, hand_model.faces, posed.vertex_normals,
                           make_background(320, 240, seed=i), raster=raster)
        extractor = FeatureExtractor(cam.name, FeaturesConfig(
            mask=MaskConfig(method='provided'), flow_enabled=False))
        cams.append(CameraObservation(cam, extractor.process(image, 0, raster.mask),
                                      SalientDetections.empty()))
    return hand_model, rig, edges, truth, FrameObservations(0, tuple(cams))


def _context(scene, theta: np.ndarray, observations: FrameObservations | None = None
             ) -> RoundContext:
    model, rig, edges, _, obs = scene
    posed = model.pose(theta)
    return RoundContext(posed, model_views(posed, edges, list(rig)),
                        observations or obs, None)


def _keypoint_error_mm(model, theta: np.ndarray, truth: np.ndarray) -> float:
    diff = model.pose(theta, jacobian=False).keypoints_m - model.pose(truth,
                                                                      jacobian=False).keypoints_m
    return 1e3 * float(np.linalg.norm(diff, axis=1).mean())


def test_jacobian_matches_central_differences(scene) -> None:
    model, *_, truth, _ = scene
    theta = truth + np.random.default_rng(1).normal(0.0, 0.02, truth.size)
    energy = EdgeEnergy.from_model(EdgeEnergyConfig(), model)
    corr = energy.correspond(_context(scene, theta))
    assert corr.n_residuals > 200
    r, J = energy.linearize(model.pose(theta), corr)
    assert r.shape == (corr.n_residuals,) and J.shape == (r.size, theta.size)
    h = 1e-6
    numeric = np.column_stack([
        (energy.residuals(model.pose(theta + h * e, jacobian=False), corr)
         - energy.residuals(model.pose(theta - h * e, jacobian=False), corr)) / (2 * h)
        for e in np.eye(theta.size)])
    np.testing.assert_allclose(J, numeric, rtol=1e-5, atol=1e-5 * np.abs(J).max())


def test_weights_palm_and_mismatch(scene) -> None:
    model, *_, truth, _ = scene
    energy = EdgeEnergy.from_model(EdgeEnergyConfig(), model)
    corr = energy.correspond(_context(scene, truth))
    low = math.sqrt(0.3)
    all_weights = np.concatenate([b.sqrt_weights for b in corr.blocks])
    assert np.any(np.isclose(all_weights, low)) and np.any(np.isclose(all_weights, 1.0))
    for block in corr.blocks:
        palm = model.vertex_part[block.vertex_ids] == 0
        assert palm.any() and (~palm).any()
        assert np.all(np.isclose(block.sqrt_weights[palm], 5.0)
                      | np.isclose(block.sqrt_weights[palm], 5.0 * low))
        assert np.all(np.isclose(block.sqrt_weights[~palm], 1.0)
                      | np.isclose(block.sqrt_weights[~palm], low))
        np.testing.assert_allclose(np.linalg.norm(block.normals_px, axis=1), 1.0)
        # At the true pose most matches sit within 1.5 px of the model contour.
        uv, _ = block.camera.project(model.pose(truth).vertices_m[block.vertex_ids])
        offset = np.abs(np.sum(block.normals_px * (uv - block.targets_px), axis=1))
        assert np.mean(offset < 1.5) > 0.7


def test_outer_contours_only(scene) -> None:
    model, *_, truth, _ = scene
    ctx = _context(scene, truth)
    both = EdgeEnergy.from_model(EdgeEnergyConfig(), model).correspond(ctx)
    outer = EdgeEnergy.from_model(EdgeEnergyConfig(inner_contours=False), model).correspond(ctx)
    inner_seen = False
    for view, b, o in zip(ctx.views, both.blocks, outer.blocks):
        outer_ids = view.contours.vertex_ids[view.contours.is_outer]
        assert o.n_rows > 0 and np.all(np.isin(o.vertex_ids, outer_ids))
        inner_seen |= bool(np.any(~np.isin(b.vertex_ids, outer_ids)))
        # An outer point kept by both finds the same image edge.
        common, ib, io = np.intersect1d(b.vertex_ids, o.vertex_ids, return_indices=True)
        assert common.size > 0.8 * o.n_rows
        np.testing.assert_allclose(b.targets_px[ib], o.targets_px[io])
    assert inner_seen


def test_fitting_the_global_pose_reduces_the_error(scene) -> None:
    model, *_, truth, _ = scene
    energy = EdgeEnergy.from_model(EdgeEnergyConfig(), model)
    free = np.zeros(truth.size, bool)
    free[:6] = True
    theta = truth.copy()
    theta[:6] += [0.006, -0.004, 0.003, 0.05, -0.04, 0.03]
    start = _keypoint_error_mm(model, theta, truth)
    for _ in range(4):
        corr = energy.correspond(_context(scene, theta))

        def fun(x, jac, corr=corr):
            posed = model.pose(x, jacobian=jac)
            return energy.linearize(posed, corr) if jac else (energy.residuals(posed, corr),
                                                             None)

        theta = levenberg_marquardt(fun, theta, model.lower, model.upper, free=free,
                                    config=_LM).x
    end = _keypoint_error_mm(model, theta, truth)
    assert start > 5.0
    assert end < 0.35 * start


def test_no_edges_hidden_hand_or_disabled_give_no_rows(scene) -> None:
    model, _, _, truth, obs = scene
    energy = EdgeEnergy.from_model(EdgeEnergyConfig(), model)
    blank = []
    for cam_obs in obs.cameras:
        f = cam_obs.features
        emap = _edge_map(np.zeros_like(f.edges.edges), 0.0)
        blank.append(CameraObservation(cam_obs.camera, type(f)(
            f.camera_name, f.stamp_ns, emap, f.mask, None, f.gray, f.roi_px, f.image_size_px),
            cam_obs.tips))
    away = truth.copy()
    away[:3] = (0.0, 0.0, 5.0)   # far outside every view
    contexts = [_context(scene, truth, FrameObservations(0, tuple(blank))),
                _context(scene, away)]
    disabled = EdgeEnergy.from_model(EdgeEnergyConfig(enabled=False), model)
    for term, ctx in [(energy, contexts[0]), (energy, contexts[1]),
                      (disabled, _context(scene, truth))]:
        corr = term.correspond(ctx)
        r, J = term.linearize(ctx.posed, corr)
        assert corr.n_residuals == 0 and r.shape == (0,) and J.shape == (0, truth.size)


def test_views_and_cameras_must_pair_up(scene) -> None:
    model, *_, truth, obs = scene
    ctx = _context(scene, truth, FrameObservations(0, obs.cameras[:1]))
    with pytest.raises(ShapeError, match='2 model views for 1 cameras'):
        EdgeEnergy.from_model(EdgeEnergyConfig(), model).correspond(ctx)
