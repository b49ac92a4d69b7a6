"""Render -> features -> fit: the tracker follows a synthetic hand and flags divergence."""
from __future__ import annotations

import numpy as np
import pytest

from hand_tracker_ros.config import from_mapping
from hand_tracker_ros.core.frames import FrameSet
from hand_tracker_ros.optim.lm import FitStatus
from hand_tracker_ros.pipeline.offline import OfflinePipeline, PipelineConfig
from hand_tracker_ros.status import TrackStatus
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence
from hand_tracker_ros.tracking.schedule import ScheduleConfig, rounds
from hand_tracker_ros.tracking.tracker import HandTracker, TrackerConfig


def _error_mm(result, frame) -> float:
    return 1e3 * float(np.linalg.norm(result.posed.keypoints_m - frame.keypoints_m,
                                      axis=1).mean())


@pytest.fixture(scope='module')
def grasp(hand_model):
    sequence = SyntheticSequence(SynthConfig(motion='grasp', n_frames=8), hand_model)
    return sequence, [sequence.frame(k) for k in range(8)]


def test_tracker_follows_a_synthetic_grasp(hand_model, grasp) -> None:
    sequence, frames = grasp
    pipeline = OfflinePipeline(hand_model, sequence.rig, PipelineConfig())
    pipeline.session.reset(frames[0].theta)
    pipeline.observe(FrameSet(frames[0].stamp_ns, frames[0].images))
    results = [pipeline.step(FrameSet(f.stamp_ns, f.images)) for f in frames[1:]]
    pipeline.close()
    errors = [_error_mm(r, f) for r, f in zip(results, frames[1:])]
    still = [1e3 * np.linalg.norm(hand_model.pose(frames[0].theta, jacobian=False).keypoints_m
                                  - f.keypoints_m, axis=1).mean() for f in frames[1:]]
    assert all(r.status == TrackStatus.TRACKING for r in results)
    assert np.mean(errors) < 5.0
    assert np.mean(errors) < 0.5 * np.mean(still)      # far better than not moving
    assert all(r.stamp_ns == f.stamp_ns for r, f in zip(results, frames[1:]))
    assert set(results[-1].energy_costs) >= {'edges', 'silhouette', 'collision'}
    # Every LM call of the kept fit reports why it stopped: 3 rounds, then separation rounds.
    assert all(len(r.lm_statuses) >= 3 for r in results)
    assert all(isinstance(s, FitStatus) for r in results for s in r.lm_statuses)


@pytest.mark.parametrize(('cap', 'rounds_n', 'separation_n'), [(10, 4, 10), (3, 3, 3)])
def test_lm_max_iterations_caps_the_rounds_and_the_separation(hand_model, grasp, cap, rounds_n,
                                                              separation_n) -> None:
    sequence, _ = grasp
    config = from_mapping(TrackerConfig, {'lm.max_iterations': cap})
    tracker = HandTracker(hand_model, sequence.rig.cameras, config)
    assert tracker._lm_config().max_iterations == rounds_n
    assert tracker._separator.lm.max_iterations == separation_n


def test_pipelined_run_gives_the_estimates_of_step_by_step(hand_model, grasp) -> None:
    """``run`` observes set k+1 while fitting set k: same estimates (edge noise included, whose
    seed follows the order of observation), ``before_fit`` right before each fit."""
    sequence, frames = grasp
    config = from_mapping(PipelineConfig, {'edge_noise.enabled': True})
    sets = [FrameSet(f.stamp_ns, f.images) for f in frames]
    thetas, events = {}, []
    for mode in ('step', 'run', 'step then run'):
        pipeline = OfflinePipeline(hand_model, sequence.rig, config)
        pipeline.session.reset(frames[0].theta)
        pipeline.observe(sets[0])
        if mode == 'step':
            results = [pipeline.step(s) for s in sets[1:]]
        elif mode == 'step then run':     # a run continues the step before it
            results = [pipeline.step(sets[1]), *pipeline.run(sets[2:])]
        else:
            results = []
            for result in pipeline.run(sets[1:], lambda s: events.append(('fit', s.stamp_ns))):
                events.append(('result', result.stamp_ns))
                results.append(result)
        pipeline.close()
        thetas[mode] = np.array([r.theta for r in results])
    np.testing.assert_array_equal(thetas['run'], thetas['step'])
    np.testing.assert_array_equal(thetas['step then run'], thetas['step'])
    assert events == [(kind, f.stamp_ns) for f in frames[1:] for kind in ('fit', 'result')]


def test_prepared_observations_fit_the_same_with_the_frame_work_done(hand_model, grasp) -> None:
    """``HandTracker.prepare`` (the pipelines call it where a set is observed) fills the
    silhouette term's per-frame lookups; a fit of unprepared observations computes the same
    ones itself and ends at the same estimate."""
    sequence, frames = grasp
    fits, caches = [], []
    for prepare in (True, False):
        pipeline = OfflinePipeline(hand_model, sequence.rig, PipelineConfig())
        pipeline.tracker.prepare = (pipeline.tracker.prepare if prepare
                                    else lambda observations: None)
        pipeline.session.reset(frames[0].theta)
        observations, _ = pipeline.observe(FrameSet(frames[1].stamp_ns, frames[1].images))
        pipeline.close()
        before = [dict(obs.features.__dict__) for obs in observations.cameras]
        fits.append(pipeline.tracker.fit(observations).theta)
        caches.append((before, [dict(obs.features.__dict__) for obs in observations.cameras]))
    keys = {'silhouette_px', '_nearest_foreground'}
    prepared, unprepared = caches
    assert all(keys <= set(cache) for cache in prepared[0])
    # The fit read what prepare filled: no other reach was computed, the same objects kept.
    for filled, after in zip(*prepared):
        assert after['silhouette_px'] is filled['silhouette_px']
        assert after['_nearest_foreground'] == filled['_nearest_foreground']
        assert len(after['_nearest_foreground']) == 1
    assert not any(keys & set(cache) for cache in unprepared[0])
    np.testing.assert_array_equal(fits[0], fits[1])


def test_perturbed_start_converges(hand_model, grasp) -> None:
    sequence, frames = grasp
    pipeline = OfflinePipeline(hand_model, sequence.rig, PipelineConfig())
    start = frames[3].theta.copy()
    start[:3] += (0.008, -0.006, 0.005)
    start[10:14] += 0.15                          # index finger off by ~9 degrees
    pipeline.session.reset(start)
    before = 1e3 * np.linalg.norm(hand_model.pose(start, jacobian=False).keypoints_m
                                  - frames[3].keypoints_m, axis=1).mean()
    result = None
    for _ in range(3):                            # the same frame, three times
        result = pipeline.step(FrameSet(frames[3].stamp_ns, frames[3].images))
    pipeline.close()
    assert _error_mm(result, frames[3]) < 0.4 * before


def test_a_hand_far_from_the_model_is_reported_lost(hand_model, grasp) -> None:
    sequence, frames = grasp
    pipeline = OfflinePipeline(hand_model, sequence.rig, PipelineConfig())
    wrong = frames[0].theta.copy()
    wrong[:3] += (0.15, 0.0, 0.1)                 # 18 cm away: no overlap with the hand
    pipeline.session.reset(wrong)
    result = pipeline.step(FrameSet(frames[1].stamp_ns, frames[1].images))
    pipeline.close()
    assert result.status == TrackStatus.LOST and pipeline.session.lost_frames == 1


def test_pso_solver_runs_on_the_same_objective(hand_model, grasp) -> None:
    sequence, frames = grasp
    config = from_mapping(PipelineConfig, {'tracker.solver': 'pso', 'tracker.pso.particles': 8,
                                           'tracker.pso.generations': 3})
    pipeline = OfflinePipeline(hand_model, sequence.rig, config)
    pipeline.session.reset(frames[0].theta)
    result = pipeline.step(FrameSet(frames[1].stamp_ns, frames[1].images))
    pipeline.close()
    assert result.iterations == 2 * 8 * 3 and _error_mm(result, frames[1]) < 15.0


def test_schedule_freezes_distal_joints_in_coarse_rounds() -> None:
    plan = rounds(ScheduleConfig(coarse_rounds=2, full_rounds=2, flow_fraction=0.5))
    assert [r.use_flow for r in plan] == [True, True, False, False]
    assert not plan[0].free.all() and plan[3].free.all()


def test_separation_rounds_separate_fingers_the_schedule_left_intersecting(hand_model,
                                                                           grasp) -> None:
    from hand_tracker_ros.geometry.triangle_pairs import face_parts, intersecting_pairs
    from hand_tracker_ros.model.layout import PARAM_NAMES

    sequence, frames = grasp
    frame = frames[3]
    start = frame.theta.copy()
    start[PARAM_NAMES.index('index_mcp_abd')] -= 0.16     # index and middle finger overlap
    start[PARAM_NAMES.index('middle_mcp_abd')] += 0.16
    face_part = face_parts(hand_model.faces, hand_model.vertex_part)

    def n_pairs(vertices_m) -> int:
        return len(intersecting_pairs(vertices_m, hand_model.faces, face_part,
                                      hand_model.adjacent_parts))

    assert n_pairs(hand_model.pose(frame.theta, jacobian=False).vertices_m) == 0
    assert n_pairs(hand_model.pose(start, jacobian=False).vertices_m) > 50
    left = []
    for extra in (0, 3):
        config = from_mapping(PipelineConfig, {
            'tracker.schedule.coarse_rounds': 0, 'tracker.schedule.full_rounds': 1,
            'tracker.schedule.iterations': 3, 'tracker.separation.rounds': extra})
        pipeline = OfflinePipeline(hand_model, sequence.rig, config)
        pipeline.session.reset(start)
        result = pipeline.step(FrameSet(frame.stamp_ns, frame.images))
        pipeline.close()
        left.append(n_pairs(result.posed.vertices_m))
    assert left[0] > 50          # one round of three LM steps leaves them intersecting
    assert left[1] == 0


def test_a_passed_deadline_stops_after_the_first_full_round(hand_model, grasp) -> None:
    import time

    sequence, frames = grasp
    pipeline = OfflinePipeline(hand_model, sequence.rig, PipelineConfig())
    pipeline.session.reset(frames[0].theta)
    observations, _ = pipeline.observe(FrameSet(frames[1].stamp_ns, frames[1].images))
    tracker, schedule = pipeline.tracker, pipeline.config.tracker.schedule
    full = tracker.fit(observations, separate=False)
    capped = tracker.fit(observations, separate=False, deadline_s=time.monotonic())
    later = tracker.fit(observations, separate=False, deadline_s=time.monotonic() + 60.0)
    pipeline.close()
    rounds = len(full.lm_statuses)          # one LM call per round (no separation)
    assert len(capped.lm_statuses) == schedule.coarse_rounds + 1 < rounds
    assert len(later.lm_statuses) == rounds
    assert capped.iterations < full.iterations == later.iterations
    np.testing.assert_allclose(later.theta, full.theta)


def test_a_fit_ends_with_its_last_round_views_carried_to_the_estimate(hand_model,
                                                                       grasp) -> None:
    """After two or more rounds the final views are the last round's start views, their
    vertex projections moved to the estimate (core.views.moved_views); a single round (a
    short fit from a hypothesis) or a separation round that moves the hand renders them at
    the estimate instead."""
    from hand_tracker_ros.core.views import model_views
    from hand_tracker_ros.model.layout import PARAM_NAMES
    from hand_tracker_ros.render.contours import MeshEdges
    from hand_tracker_ros.tracking.schedule import QUICK

    sequence, frames = grasp
    pipeline = OfflinePipeline(hand_model, sequence.rig, PipelineConfig())
    pipeline.session.reset(frames[0].theta)
    observations, _ = pipeline.observe(FrameSet(frames[1].stamp_ns, frames[1].images))
    fit = pipeline.tracker.fit(observations)
    edges = MeshEdges.from_faces(hand_model.faces)
    rendered = model_views(fit.posed, edges, sequence.rig.cameras)
    changed = []
    for view, fresh in zip(fit.views, rendered):
        uv, depth = view.camera.project(fit.posed.vertices_m)
        np.testing.assert_array_equal(view.raster.uv_px, uv)
        np.testing.assert_array_equal(view.raster.vertex_depth_m, depth)
        np.testing.assert_array_equal(view.contours.uv_px, uv[view.contours.vertex_ids])
        # The raster is the last round's start, a pose a fraction of a pixel away.
        changed.append((view.raster.mask != fresh.raster.mask).mean())
    assert 0.0 < max(changed) < 0.002
    # carry_views_px 0: a round that moved the contour at all renders them again.
    exact = OfflinePipeline(hand_model, sequence.rig,
                            from_mapping(PipelineConfig, {'tracker.carry_views_px': 0.0}))
    exact.session.reset(frames[0].theta)
    fit = exact.tracker.fit(observations)
    exact.close()
    for view, fresh in zip(fit.views, model_views(fit.posed, edges, sequence.rig.cameras)):
        np.testing.assert_array_equal(view.raster.mask, fresh.raster.mask)
    # One round from a perturbed start (a hypothesis' short fit): rendered at the estimate.
    start = frames[1].theta.copy()
    start[PARAM_NAMES.index('index_mcp_flex')] += 0.3
    short = pipeline.tracker.fit(observations, start, plan=QUICK, separate=False)
    for view, fresh in zip(short.views, model_views(short.posed, edges, sequence.rig.cameras)):
        np.testing.assert_array_equal(view.raster.mask, fresh.raster.mask)
    # From intersecting fingers the separation rounds move the hand: rendered at the estimate.
    start = frames[3].theta.copy()
    start[PARAM_NAMES.index('index_mcp_abd')] -= 0.16
    start[PARAM_NAMES.index('middle_mcp_abd')] += 0.16
    config = from_mapping(PipelineConfig, {'tracker.schedule.coarse_rounds': 0,
                                           'tracker.schedule.full_rounds': 2,
                                           'tracker.schedule.iterations': 2})
    separating = OfflinePipeline(hand_model, sequence.rig, config)
    separating.session.reset(start)
    observations, _ = separating.observe(FrameSet(frames[3].stamp_ns, frames[3].images))
    fit = separating.tracker.fit(observations)
    assert fit.iterations > 4             # separation rounds ran after the two rounds
    for view, fresh in zip(fit.views, model_views(fit.posed, edges, sequence.rig.cameras)):
        np.testing.assert_array_equal(view.raster.mask, fresh.raster.mask)
        np.testing.assert_array_equal(view.contours.vertex_ids, fresh.contours.vertex_ids)
    pipeline.close()
    separating.close()


def test_contour_shift_is_the_largest_camera_median(hand_model, grasp) -> None:
    from hand_tracker_ros.core.views import contour_shift_px, model_views, moved_views
    from hand_tracker_ros.render.contours import MeshEdges

    sequence, frames = grasp
    edges = MeshEdges.from_faces(hand_model.faces)
    posed = hand_model.pose(frames[2].theta, jacobian=False)
    views = model_views(posed, edges, sequence.rig.cameras)
    assert contour_shift_px(views, posed) == 0.0
    theta = frames[2].theta.copy()
    theta[0] += 0.002                    # 2 mm along x: about a pixel or two in every camera
    moved_pose = hand_model.pose(theta, jacobian=False)
    moved = moved_views(views, moved_pose)
    expected = max(float(np.median(np.linalg.norm(
        m.raster.uv_px[v.contours.vertex_ids] - v.raster.uv_px[v.contours.vertex_ids],
        axis=1))) for v, m in zip(views, moved))
    assert contour_shift_px(views, moved_pose) == pytest.approx(expected)
    assert 0.5 < expected < 5.0


def test_reshape_keeps_the_history_posed_on_the_new_model(hand_model, grasp) -> None:
    from hand_tracker_ros.model.hand import HandModel
    from hand_tracker_ros.model.shape import HandShape

    sequence, frames = grasp
    tracker = HandTracker(hand_model, sequence.rig.cameras)
    tracker.reset(frames[0].theta)
    before = tracker.last_posed
    larger = HandModel.build(HandShape(scale=1.08))
    tracker.reshape(larger)
    np.testing.assert_array_equal(tracker.history, frames[0].theta[None])
    assert tracker.model is larger and tracker.last_posed.model is larger
    # A result posed on the earlier model is still rendered with that model's mesh.
    old_views = tracker.views(before)
    assert all(v.raster.mask.sum() < w.raster.mask.sum()
               for v, w in zip(old_views, tracker.views(tracker.last_posed)))
