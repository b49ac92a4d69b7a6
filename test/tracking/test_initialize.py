"""Initialization from observations: the visual hull and the hypothesis search."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.stats

from hand_tracker_ros._typing import FloatArray
from hand_tracker_ros.core.frames import FrameSet
from hand_tracker_ros.errors import HandTrackerError, ShapeError
from hand_tracker_ros.geometry.rig import CameraRig
from hand_tracker_ros.pipeline.offline import OfflinePipeline, PipelineConfig
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence
from hand_tracker_ros.tracking.evidence import CoarseMasks, silhouette_iou
from hand_tracker_ros.tracking.initialize import (
    HandRegion,
    InitConfig,
    VisualHull,
    hypotheses,
    ranked_hypotheses,
)


def _ball_masks(rig, centre, radius_px=6.0):
    masks = []
    for camera in rig.cameras:
        uv, _ = camera.project(centre[None])
        vv, uu = np.mgrid[:120, :160]
        masks.append((uu - uv[0, 0]) ** 2 + (vv - uv[0, 1]) ** 2 < radius_px ** 2)
    return masks


def test_the_visual_hull_places_a_ball_and_ignores_clutter_in_one_camera() -> None:
    rig = CameraRig.ring(3, 160, 120)
    centre = np.array([0.02, -0.01, 0.03])
    masks = _ball_masks(rig, centre)
    hull = VisualHull(rig.cameras)

    def locate(masks, min_px):
        return hull.region(masks, min_px).centre_m

    np.testing.assert_allclose(locate(masks, 10), centre, atol=3e-3)
    cluttered = [masks[0] | _ball_masks(rig, np.array([-0.1, 0.12, -0.05]), 15.0)[0],
                 *masks[1:]]
    np.testing.assert_allclose(locate(cluttered, 10), centre, atol=3e-3)
    # A camera that sees foreground everywhere carves nothing: what the others see stays.
    np.testing.assert_allclose(locate([masks[0] | True, *masks[1:]], 10), centre, atol=3e-3)
    with pytest.raises(HandTrackerError, match='only 1 camera'):
        locate([masks[0], masks[1] & False, masks[2] & False], 10)
    apart = [masks[0], _ball_masks(rig, np.array([0.1, 0.1, 0.0]))[1], masks[2]]
    with pytest.raises(HandTrackerError, match='do not intersect'):
        locate(apart, 10)
    with pytest.raises(ShapeError, match='masks for 3 cameras'):
        locate(masks[:2], 10)
    with pytest.raises(ShapeError, match='a 80x60 mask'):
        locate([m[::2, ::2] for m in masks], 10)


def test_a_kept_visual_hull_locates_as_a_new_one_whichever_cameras_see_foreground() -> None:
    rig = CameraRig.ring(4, 160, 120)
    hull = VisualHull(rig.cameras)
    cases = [((0.02, -0.01, 0.03), (0, 1, 2, 3)), ((-0.03, 0.02, 0.0), (0, 2, 3)),
             ((0.0, 0.03, -0.02), (0, 1, 2, 3)), ((0.01, 0.0, 0.01), (1, 3)),
             ((0.0, 0.0, 0.0), (0, 1)), ((0.01, 0.01, 0.0), (1, 2)),
             ((0.02, -0.01, 0.03), (0, 1, 2, 3))]       # more camera sets than are kept
    for centre, seeing in cases:
        masks = [m if c in seeing else m & False
                 for c, m in enumerate(_ball_masks(rig, np.array(centre)))]
        found = hull.region(masks, 10).centre_m
        fresh = VisualHull(rig.cameras).region(masks, 10).centre_m
        np.testing.assert_array_equal(found, fresh)
        np.testing.assert_allclose(found, centre, atol=3e-3)


def test_masks_of_a_region_of_interest_are_placed_in_the_image() -> None:
    rig = CameraRig.ring(3, 160, 120)
    centre = np.array([0.02, -0.01, 0.03])
    masks = _ball_masks(rig, centre)
    hull = VisualHull(rig.cameras)
    boxes, crops = [], []
    for mask in masks:
        rows, cols = np.nonzero(mask)
        box = (int(cols.min()) - 5, int(rows.min()) - 7, int(cols.max()) + 9, int(rows.max()) + 4)
        boxes.append(box)
        crops.append(mask[box[1]:box[3], box[0]:box[2]])
    np.testing.assert_array_equal(hull.region(crops, 10, boxes).centre_m,
                                  hull.region(masks, 10).centre_m)
    # The same crops read as if they covered the image's top-left corner: elsewhere.
    with pytest.raises(HandTrackerError, match='do not intersect'):
        hull.region([np.pad(c, ((0, 120 - c.shape[0]), (0, 160 - c.shape[1])))
                     for c in crops], 10)


@pytest.mark.slow
def test_pipeline_finds_the_hand_without_a_given_pose(hand_model) -> None:
    sequence = SyntheticSequence(SynthConfig(motion='wrist', n_frames=12), hand_model)
    frame = sequence.frame(10)
    pipeline = OfflinePipeline(hand_model, sequence.rig, PipelineConfig())
    result = pipeline.step(FrameSet(frame.stamp_ns, frame.images))
    pipeline.close()
    error = 1e3 * np.linalg.norm(result.posed.keypoints_m - frame.keypoints_m, axis=1).mean()
    assert error < 10.0 and 'initialize' in result.timings_s


@pytest.fixture(scope='module')
def grasp(hand_model):
    """A grasp frame (seed 9), its observations and a tracker of its rig."""
    sequence = SyntheticSequence(SynthConfig(motion='grasp', n_frames=2, seed=9), hand_model)
    frame = sequence.frame(1)
    pipeline = OfflinePipeline(hand_model, sequence.rig)
    observations, _ = pipeline.observe(FrameSet(frame.stamp_ns, frame.images))
    pipeline.close()
    tracker = pipeline.session.tracker
    return frame, observations, tracker


def test_the_coarse_splat_iou_ranks_poses_as_the_rendered_silhouette_does(hand_model,
                                                                          grasp) -> None:
    """The cheap ranking of the start hypotheses (no rendering) agrees with the rendered
    silhouette IoU: at the true pose the two IoUs are close (both below 1: the skin mask
    also holds clutter) and above every relaxed hypothesis, and the hypotheses at the hand's
    centre are ranked alike (Spearman's rho)."""
    frame, observations, tracker = grasp
    masks = CoarseMasks(observations, tracker.cameras)
    centre = hand_model.pose(frame.theta, jacobian=False).vertices_m.mean(axis=0)
    starts = hypotheses(hand_model, centre, InitConfig())
    splat = np.array([masks.iou(hand_model.pose(t, jacobian=False).vertices_m) for t in starts])
    rendered = np.array([silhouette_iou(tracker.views(hand_model.pose(t, jacobian=False)),
                                        observations) for t in starts])
    posed = hand_model.pose(frame.theta, jacobian=False)
    truth = masks.iou(posed.vertices_m)
    assert abs(truth - silhouette_iou(tracker.views(posed), observations)) < 0.1
    assert truth > splat.max()
    assert scipy.stats.spearmanr(splat, rendered)[0] > 0.9
    unslid = InitConfig(slide_best=0)
    ranked = ranked_hypotheses(tracker, observations, HandRegion(centre, np.eye(3)[0]), unslid)
    np.testing.assert_array_equal(ranked[0], starts[int(np.argmax(splat))])


@pytest.mark.parametrize('offset_mm', [-20.0, 20.0])
def test_hypotheses_slid_along_the_hull_axis_move_onto_the_hand(hand_model, grasp,
                                                                offset_mm) -> None:
    """The hull's centroid misses the hand mostly along its long axis; a region 20 mm off
    the hand along that axis puts the unslid hypotheses 20 mm off, and the slid best ones
    on the hand."""
    frame, observations, tracker = grasp
    hand_m = hand_model.pose(frame.theta, jacobian=False).vertices_m.mean(axis=0)
    axis = VisualHull(tracker.cameras).locate(observations, 50).axis
    region = HandRegion(hand_m + 1e-3 * offset_mm * axis, axis)

    def miss_mm(config: InitConfig) -> FloatArray:
        best = ranked_hypotheses(tracker, observations, region, config)[:3]
        return np.array([1e3 * np.linalg.norm(
            hand_model.pose(theta, jacobian=False).vertices_m.mean(axis=0) - hand_m)
            for theta in best])

    np.testing.assert_allclose(miss_mm(InitConfig(slide_best=0)), 20.0, atol=1e-6)
    assert np.all(miss_mm(InitConfig()) < 5.0)


def test_the_hull_region_axis_follows_the_longest_extent() -> None:
    rig = CameraRig.ring(4, 160, 120)
    along = np.array([0.6, 0.0, 0.8])
    centres = [k * 0.01 * along for k in range(-4, 5)]
    masks = [np.logical_or.reduce([m[c] for m in (_ball_masks(rig, p) for p in centres)])
             for c in range(4)]
    region = VisualHull(rig.cameras).region(masks, 10)
    np.testing.assert_allclose(region.centre_m, 0.0, atol=3e-3)
    assert abs(region.axis @ along) > 0.95
