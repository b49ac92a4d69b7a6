"""Silhouette term Sil: closest data-silhouette pixel, point-to-ray residuals, fitting."""
from __future__ import annotations

import dataclasses

import cv2
import numpy as np
import pytest
import scipy.spatial

from hand_tracker_ros.core.context import RoundContext
from hand_tracker_ros.core.observations import CameraObservation, FrameObservations
from hand_tracker_ros.core.views import model_views
from hand_tracker_ros.energies.silhouette import (
    SilhouetteConfig,
    SilhouetteEnergy,
    floods,
    nearest_point,
    outside_targets,
)
from hand_tracker_ros.errors import ShapeError
from hand_tracker_ros.geometry.rig import CameraRig
from hand_tracker_ros.model.layout import PARAM_NAMES
from hand_tracker_ros.optim.lm import LMConfig, levenberg_marquardt
from hand_tracker_ros.render.background import make_background
from hand_tracker_ros.render.contours import MeshEdges
from hand_tracker_ros.render.rasterizer import render
from hand_tracker_ros.render.shading import render_rgb
from hand_tracker_ros.vision.detections import SalientDetections
from hand_tracker_ros.vision.features import CameraFeatures, FeatureExtractor, FeaturesConfig
from hand_tracker_ros.vision.mask import MaskConfig

_TRANSLATION = (0.0, -0.08, -0.02)
# Tau small enough that the first LM steps are not over-damped on the finger columns.
_LM = LMConfig(max_iterations=5, tau=1e-9)


def _with_mask(features: CameraFeatures, mask: np.ndarray,
               roi: tuple[int, int, int, int] | None = None) -> CameraFeatures:
    return CameraFeatures(features.camera_name, features.stamp_ns, features.edges, mask,
                          None, features.gray, roi or features.roi_px, features.image_size_px)


def test_outside_targets_exact_on_a_box_with_cap_and_roi() -> None:
    mask = np.zeros((40, 60), bool)
    mask[10:20, 30:40] = True                      # ROI pixels; full image = ROI + (100, 50)
    features = CameraFeatures('c', 0, None, mask, None, np.zeros((40, 60), np.uint8),
                              (100, 50, 160, 90), (320, 240))
    uv = np.array([[125.2, 65.0], [135.0, 55.4], [145.0, 75.0], [90.0, 65.0], [132, 62],
                   [129.6, 65.0]])
    matched, target = outside_targets(features, uv, 12.0, 1.0)
    # Beyond the cap, inside the mask and within the tolerance: no match.
    np.testing.assert_array_equal(matched, [True, True, True, False, False, False])
    np.testing.assert_allclose(target[:3], [[129.5, 65], [135, 59.5],
                                            [139 + 0.5 / np.sqrt(2), 69 + 0.5 / np.sqrt(2)]])
    empty = _with_mask(features, np.zeros_like(mask))
    assert not outside_targets(empty, uv, 12.0, 1.0)[0].any()
    assert outside_targets(features, np.zeros((0, 2)), 12.0, 1.0)[1].shape == (0, 2)


def _outside_targets_numpy(features: CameraFeatures, uv: np.ndarray, cap: float, tol: float
                           ) -> tuple[np.ndarray, np.ndarray]:
    """Reference: mask test, distance transform of the queries' window, target, in numpy."""
    outside = ~features.mask_at(uv)
    matched, target = np.zeros(len(uv), bool), np.zeros((len(uv), 2))
    u0, v0, u1, v1 = features.roi_px
    reach = int(np.ceil(cap)) + 1
    lo = np.floor(uv[outside].min(axis=0)).astype(int) - reach
    hi = np.ceil(uv[outside].max(axis=0)).astype(int) + reach + 1
    wu0, wv0, wu1, wv1 = max(lo[0], u0), max(lo[1], v0), min(hi[0], u1), min(hi[1], v1)
    window = features.mask[wv0 - v0:wv1 - v0, wu0 - u0:wu1 - u0]
    _, labels = cv2.distanceTransformWithLabels(np.where(window, 0, 255).astype(np.uint8),
                                                cv2.DIST_L2, 5, labelType=cv2.DIST_LABEL_PIXEL)
    col = np.clip(np.rint(uv[:, 0]).astype(int) - wu0, 0, wu1 - wu0 - 1)
    row = np.clip(np.rint(uv[:, 1]).astype(int) - wv0, 0, wv1 - wv0 - 1)
    flat = np.flatnonzero(window)[labels[row, col] - 1]
    pixel = np.column_stack([flat % (wu1 - wu0) + wu0, flat // (wu1 - wu0) + wv0]).astype(float)
    offset = uv - pixel
    gap = np.linalg.norm(offset, axis=1)
    matched = outside & (np.hypot(*(pixel - uv).T) <= cap) & (gap > tol)
    target[matched] = pixel[matched] + 0.5 * offset[matched] / gap[matched, None]
    return matched, target


def test_outside_targets_match_the_numpy_form_on_random_blobs() -> None:
    """Labels from the per-frame window around the foreground equal those of the queries'
    window (the former per-round form) wherever a match is found."""
    rng = np.random.default_rng(3)
    for trial in range(20):
        mask = np.zeros((150, 200), np.uint8)
        for _ in range(3):
            cv2.ellipse(mask, tuple(int(c) for c in rng.integers(40, 120, 2)),
                        tuple(int(a) for a in rng.integers(4, 25, 2)), float(rng.uniform(0, 180)),
                        0, 360, 1, -1)
        roi = (trial, 2 * trial, trial + 200, 2 * trial + 150)
        features = CameraFeatures('c', 0, None, mask.astype(bool), None, mask, roi, (320, 240))
        uv = rng.uniform(-15, 215, (1000, 2)) + roi[:2]
        matched, target = outside_targets(features, uv, 20.0, 1.0)
        ref_matched, ref_target = _outside_targets_numpy(features, uv, 20.0, 1.0)
        assert ref_matched.sum() > 50
        np.testing.assert_array_equal(matched, ref_matched)
        np.testing.assert_array_equal(target, ref_target)


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


def _fit(scene, energy: SilhouetteEnergy, theta: np.ndarray, free: np.ndarray,
         rounds: int) -> np.ndarray:
    model = scene[0]
    for _ in range(rounds):
        corr = energy.correspond(_context(scene, theta))

        def fun(x, jac, corr=corr):
            posed = model.pose(x, jacobian=jac)
            return energy.linearize(posed, corr) if jac else (energy.residuals(posed, corr),
                                                             None)

        theta = levenberg_marquardt(fun, theta, model.lower, model.upper, free=free,
                                    config=_LM).x
    return theta


def _keypoint_error_mm(model, theta: np.ndarray, truth: np.ndarray) -> float:
    diff = model.pose(theta, jacobian=False).keypoints_m - model.pose(truth,
                                                                      jacobian=False).keypoints_m
    return 1e3 * float(np.linalg.norm(diff, axis=1).mean())


def _perturbed(truth: np.ndarray) -> np.ndarray:
    theta = truth.copy()
    theta[:6] += [0.006, -0.004, 0.003, 0.05, -0.04, 0.03]
    return theta


def test_nearest_point_matches_a_kd_tree() -> None:
    rng = np.random.default_rng(5)
    points = rng.uniform(0, 100, (300, 2))
    queries = rng.uniform(-20, 120, (400, 2))
    gap, index = nearest_point(queries, points, 6.0)
    ref_gap, ref_index = scipy.spatial.cKDTree(points).query(queries, distance_upper_bound=6.0)
    assert np.isinf(gap).any() and np.isfinite(gap).any()
    np.testing.assert_array_equal(index, ref_index)
    np.testing.assert_allclose(gap, ref_gap, rtol=1e-12)
    gap, index = nearest_point(queries, np.zeros((0, 2)), 6.0)
    assert np.isinf(gap).all() and (index == 0).all()


def test_nearest_point_breaks_ties_by_the_lowest_index_like_a_full_scan() -> None:
    # Points and queries on a pixel grid: many are equally near (and some exactly at the reach).
    rng = np.random.default_rng(8)
    points = rng.integers(0, 30, (200, 2)).astype(np.float64)
    queries = rng.integers(-5, 35, (300, 2)).astype(np.float64)
    gap, index = nearest_point(queries, points, 3.0)
    d2 = ((queries[:, None, :] - points[None, :, :]) ** 2).sum(axis=2)
    d2[d2 >= 9.0] = np.inf                      # strictly within the reach
    hit = np.isfinite(d2).any(axis=1)
    assert hit.any() and not hit.all()
    np.testing.assert_array_equal(index[hit], np.argmin(d2[hit], axis=1))   # first minimum
    np.testing.assert_array_equal(index[~hit], len(points))
    np.testing.assert_array_equal(gap[hit], np.sqrt(d2[hit].min(axis=1)))


def test_jacobian_matches_central_differences(scene) -> None:
    model, *_, truth, _ = scene
    theta = _perturbed(truth) + np.random.default_rng(2).normal(0.0, 0.02, truth.size)
    energy = SilhouetteEnergy.from_model(SilhouetteConfig(), model)
    corr = energy.correspond(_context(scene, theta))
    assert corr.n_residuals > 100
    r, J = energy.linearize(model.pose(theta), corr)
    assert r.shape == (corr.n_residuals,) and J.shape == (r.size, theta.size)
    h = 1e-6
    numeric = np.column_stack([
        (energy.residuals(model.pose(theta + h * e, jacobian=False), corr)
         - energy.residuals(model.pose(theta - h * e, jacobian=False), corr)) / (2 * h)
        for e in np.eye(theta.size)])
    np.testing.assert_allclose(J, numeric, rtol=1e-5, atol=1e-7)


def test_residual_is_the_distance_to_the_ray_of_a_silhouette_pixel(scene) -> None:
    model, rig, _, truth, obs = scene
    theta = _perturbed(truth)
    energy = SilhouetteEnergy.from_model(SilhouetteConfig(max_points_per_camera=10000,
                                                          data_to_model_weight=0.0), model)
    ctx = _context(scene, theta)
    corr = energy.correspond(ctx)
    posed = ctx.posed
    r = energy.residuals(posed, corr)
    assert np.all(r > 0) and np.all(r < 0.03)                       # metres
    foot = posed.vertices_m[corr.vertex_ids] - r[:, None] * corr.normals
    for cam, cam_obs in zip(rig, obs.cameras):
        rows = np.flatnonzero(np.all(np.isclose(corr.ray_origins_m, cam.center_world), axis=1))
        assert rows.size > 0
        uv_foot, _ = cam.project(foot[rows])
        uv_model, _ = cam.project(posed.vertices_m[corr.vertex_ids[rows]])
        assert not cam_obs.features.mask_at(uv_model).any()         # model points outside
        fg = np.argwhere(cam_obs.features.mask)[:, ::-1]            # (u, v) of foreground
        gap = np.min(np.linalg.norm(uv_foot[:, None] - fg[None], axis=2), axis=1)
        np.testing.assert_allclose(gap, 0.5, atol=1e-6)  # on the pixel edge of the silhouette
        np.testing.assert_allclose(np.einsum('ni,ni->n', corr.normals[rows],
                                             foot[rows] - cam.center_world), 0, atol=1e-12)


def test_data_to_model_rows_reach_uncovered_silhouette_pixels(scene) -> None:
    _, _, _, truth, obs = scene
    theta = _perturbed(truth)
    one_way = SilhouetteConfig(max_points_per_camera=10000, data_to_model_weight=0.0)
    both = SilhouetteConfig(max_points_per_camera=10000, data_to_model_weight=1.0)
    ctx = _context(scene, theta)
    n_model = SilhouetteEnergy(one_way).correspond(ctx).n_residuals
    corr = SilhouetteEnergy(both).correspond(ctx)
    rows = np.arange(n_model, corr.n_residuals)
    assert rows.size > 50
    r = SilhouetteEnergy(both).residuals(ctx.posed, corr)[rows]
    np.testing.assert_array_less(0.0, r)
    foot = ctx.posed.vertices_m[corr.vertex_ids[rows]] - r[:, None] * corr.normals[rows]
    for view, cam_obs in zip(ctx.views, obs.cameras):
        mine = np.all(np.isclose(corr.ray_origins_m[rows], view.camera.center_world), axis=1)
        uv_foot, _ = view.camera.project(foot[mine])
        # Data silhouette pixels the model does not cover, half a pixel inside the boundary.
        data = cam_obs.features.mask & ~cv2.erode(cam_obs.features.mask.astype(np.uint8),
                                                  np.ones((3, 3), np.uint8)).astype(bool)
        fg = np.argwhere(data & ~view.raster.mask)[:, ::-1]
        gap = np.min(np.linalg.norm(uv_foot[:, None] - fg[None], axis=2), axis=1)
        np.testing.assert_allclose(gap, 0.5, atol=1e-6)


def test_data_to_model_weight_scales_only_the_data_rows(scene) -> None:
    theta = _perturbed(scene[3])
    ctx = _context(scene, theta)
    unit, heavy = (SilhouetteEnergy(SilhouetteConfig(data_to_model_weight=w)) for w in (1.0, 4.0))
    n_model = SilhouetteEnergy(SilhouetteConfig(data_to_model_weight=0.0)).correspond(
        ctx).n_residuals
    r_unit = unit.residuals(ctx.posed, unit.correspond(ctx))
    r_heavy = heavy.residuals(ctx.posed, heavy.correspond(ctx))
    assert r_unit.size > n_model
    np.testing.assert_allclose(r_heavy[:n_model], r_unit[:n_model])
    np.testing.assert_allclose(r_heavy[n_model:], 2.0 * r_unit[n_model:])


def test_data_to_model_pulls_a_too_small_model_back(scene) -> None:
    # One camera; the model 4 cm too far away looks smaller than the data silhouette, so
    # only the data-to-model rows can pull it closer.
    model, rig, edges, truth, obs = scene
    one_cam = (model, CameraRig((rig[0],)), edges, truth,
               FrameObservations(0, obs.cameras[:1]))
    axis = rig[0].R_cam_world[2]
    theta = truth.copy()
    theta[:3] += 0.04 * axis
    free = np.zeros(truth.size, bool)
    free[:3] = True
    errors = []
    for push in (0.0, 1.0):
        energy = SilhouetteEnergy(SilhouetteConfig(data_to_model_weight=push))
        fitted = _fit(one_cam, energy, theta, free, 4)
        errors.append(np.linalg.norm(fitted[:3] - truth[:3]))
    assert errors[0] > 0.03
    assert errors[1] < 0.01


def _data_rows(scene, theta: np.ndarray, observations: FrameObservations, views: bool
               ) -> int:
    ctx = _context(scene, theta, observations)
    config = SilhouetteConfig(max_points_per_camera=10000, data_to_model_views=views)
    model_rows = SilhouetteEnergy(SilhouetteConfig(max_points_per_camera=10000,
                                                   data_to_model_weight=0.0))
    return (SilhouetteEnergy(config).correspond(ctx).n_residuals
            - model_rows.correspond(ctx).n_residuals)


def test_data_to_model_rows_of_clutter_seen_by_one_camera_only_are_dropped(scene) -> None:
    # A skin-coloured blob touching the hand in camera 0's mask alone: uncovered foreground
    # there, whose rows would pull the model into it; camera 1 sees background behind it.
    _, _, _, truth, obs = scene
    features = obs.cameras[0].features
    mask = features.mask.copy()
    rows, cols = np.nonzero(mask)
    centre = (int(cols.max()) + 6, int(rows.mean()))
    cv2.circle(mask.view(np.uint8), centre, 10, 1, -1)
    cluttered = FrameObservations(0, (CameraObservation(obs.cameras[0].camera,
                                                        _with_mask(features, mask),
                                                        SalientDetections.empty()),
                                      obs.cameras[1]))
    clutter_rows = (_data_rows(scene, truth, cluttered, views=False)
                    - _data_rows(scene, truth, obs, views=False))
    kept = (_data_rows(scene, truth, cluttered, views=True)
            - _data_rows(scene, truth, obs, views=True))
    assert clutter_rows > 20
    # Rows of blob pixels next to the hand's own silhouette pass within the tolerance
    # (12 of 48 here).
    assert kept <= 0.3 * clutter_rows


def test_data_to_model_rows_of_the_hand_are_kept_by_the_other_views(scene) -> None:
    # The model moved off the data: the uncovered pixels are the hand, which both cameras see.
    _, _, _, truth, obs = scene
    theta = _perturbed(truth)
    unchecked = _data_rows(scene, theta, obs, views=False)
    assert unchecked > 50
    assert _data_rows(scene, theta, obs, views=True) >= 0.9 * unchecked


def _camera_rows(scene, observations: FrameObservations, config: SilhouetteConfig
                 ) -> list[int]:
    """Data-to-model rows per camera at the true pose."""
    ctx = _context(scene, scene[3], observations)
    model_rows = SilhouetteEnergy(dataclasses.replace(config, data_to_model_weight=0.0))
    corr = SilhouetteEnergy(config).correspond(ctx)
    data = slice(model_rows.correspond(ctx).n_residuals, None)
    return [int(np.all(np.isclose(corr.ray_origins_m[data], view.camera.center_world),
                       axis=1).sum()) for view in ctx.views]


def test_a_camera_whose_mask_floods_the_hand_gives_no_data_to_model_rows(scene) -> None:
    # A skin-coloured background filling camera 0's left half merges with the hand: its
    # boundary crosses the hand, and rows there would pull the fingers onto it.
    _, _, _, _, obs = scene
    features = obs.cameras[0].features
    cols = np.nonzero(features.mask)[1]
    flooded = features.mask.copy()
    flooded[:, :int(np.median(cols))] = True
    observations = FrameObservations(0, (CameraObservation(
        obs.cameras[0].camera, _with_mask(features, flooded), SalientDetections.empty()),
        obs.cameras[1]))
    config = SilhouetteConfig(max_points_per_camera=10000, data_to_model_views=False)
    unchecked = _camera_rows(scene, observations,
                             dataclasses.replace(config, data_to_model_max_foreground=1000.0))
    assert unchecked[0] > 20
    assert _camera_rows(scene, observations, config) == [0, unchecked[1]]
    # The clean mask, about the model's own area, does not flood it.
    ctx = _context(scene, _perturbed(scene[3]))
    assert not floods(ctx.views[0], features, config.data_to_model_reach,
                      config.data_to_model_max_foreground)
    assert floods(ctx.views[0], observations.cameras[0].features, config.data_to_model_reach,
                  config.data_to_model_max_foreground)


def test_true_pose_has_few_small_residuals(scene) -> None:
    model, *_, truth, _ = scene
    energy = SilhouetteEnergy.from_model(SilhouetteConfig(), model)
    ctx = _context(scene, truth)
    at_truth = energy.correspond(ctx)
    off = energy.correspond(_context(scene, _perturbed(truth)))
    assert at_truth.n_residuals < 0.3 * off.n_residuals
    assert np.max(np.abs(energy.residuals(ctx.posed, at_truth)), initial=0.0) < 0.003


def test_fitting_the_global_pose_reduces_the_error(scene) -> None:
    model, *_, truth, _ = scene
    energy = SilhouetteEnergy.from_model(SilhouetteConfig(), model)
    free = np.zeros(truth.size, bool)
    free[:6] = True
    theta = _perturbed(truth)
    start = _keypoint_error_mm(model, theta, truth)
    end = _keypoint_error_mm(model, _fit(scene, energy, theta, free, 4), truth)
    assert start > 5.0
    assert end < 0.35 * start


def test_a_finger_sticking_out_is_pulled_back(scene) -> None:
    model, *_, truth, _ = scene
    energy = SilhouetteEnergy.from_model(SilhouetteConfig(), model)
    finger = [PARAM_NAMES.index(n) for n in ('index_mcp_flex', 'index_mcp_abd')]
    free = np.zeros(truth.size, bool)
    free[finger] = True
    theta = truth.copy()
    theta[finger] += [-0.25, 0.2]
    fitted = _fit(scene, energy, theta, free, 3)
    assert np.linalg.norm(fitted[finger] - truth[finger]) < 0.3 * np.linalg.norm(
        theta[finger] - truth[finger])


def test_empty_mask_hidden_hand_or_disabled_give_no_rows(scene) -> None:
    model, _, _, truth, obs = scene
    energy = SilhouetteEnergy.from_model(SilhouetteConfig(), model)
    blank = FrameObservations(0, tuple(
        CameraObservation(c.camera, _with_mask(c.features, np.zeros_like(c.features.mask)),
                          c.tips) for c in obs.cameras))
    away = truth.copy()
    away[:3] = (0.0, 0.0, 5.0)   # far outside every view
    disabled = SilhouetteEnergy.from_model(SilhouetteConfig(enabled=False), model)
    for term, ctx in [(energy, _context(scene, _perturbed(truth), blank)),
                      (energy, _context(scene, away)),
                      (disabled, _context(scene, _perturbed(truth)))]:
        corr = term.correspond(ctx)
        r, J = term.linearize(ctx.posed, corr)
        assert corr.n_residuals == 0 and r.shape == (0,) and J.shape == (0, truth.size)


def test_views_and_cameras_must_pair_up(scene) -> None:
    model, *_, truth, obs = scene
    ctx = _context(scene, truth, FrameObservations(0, obs.cameras[:1]))
    with pytest.raises(ShapeError, match='2 model views for 1 cameras'):
        SilhouetteEnergy.from_model(SilhouetteConfig(), model).correspond(ctx)
