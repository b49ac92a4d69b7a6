from __future__ import annotations

import dataclasses

import cv2
import numpy as np
import pytest

from hand_tracker_ros.config import validate
from hand_tracker_ros.errors import ConfigError, ImageFormatError
from hand_tracker_ros.vision.detector.channels import (candidates, compute_channels,
                                                       feature_matrix, gate_image)
from hand_tracker_ros.vision.detector.data import labelled_views
from hand_tracker_ros.vision.detector.detector import (DetectorConfig, FingertipDetector,
                                                       find_peaks, refine, smooth_votes)
from hand_tracker_ros.vision.detector.evaluation import DetectionTally
from hand_tracker_ros.vision.detector.forest import ForestArrays, pack_nodes, vote
from hand_tracker_ros.vision.detector.model import DetectorModel

# Seeds the shipped model (seed 0) was not trained on.
TEST_SEED = 987_654


@pytest.fixture(scope='module')
def detector():
    return FingertipDetector.load()


@pytest.fixture(scope='module')
def views():
    return list(labelled_views(24, TEST_SEED))


def test_shipped_model_finds_visible_tips_on_held_out_views(detector, views):
    tally = DetectionTally()
    for view in views:
        tally.add(detector.detect(view.image), view.tips_uv, view.tips_visible)
    assert tally.visible_tips > 40
    # Looser than the bench bar (few views), far above what a broken model reaches.
    assert tally.recall > 0.55
    assert tally.precision > 0.55
    assert np.median(tally.errors_px) < 4.0


def test_verifier_beats_vote_height_on_held_out_views(detector, views):
    # One-leaf verifiers of probability 1 keep the 5 highest vote peaks: the ranking of
    # a detector without the verifier stages.
    accept_all = ForestArrays(roots=np.zeros(1, np.int32), left=np.full(1, -1, np.int32),
                              right=np.full(1, -1, np.int32), feature=np.full(1, -1, np.int32),
                              threshold=np.zeros(1), value=np.ones((1, 1)))
    plain = FingertipDetector(dataclasses.replace(detector.model, verifier=accept_all,
                                                  context=accept_all))
    verified, unverified = DetectionTally(), DetectionTally()
    for view in views:
        verified.add(detector.detect(view.image), view.tips_uv, view.tips_visible)
        unverified.add(plain.detect(view.image), view.tips_uv, view.tips_visible)
    assert verified.precision > unverified.precision + 0.1


def test_peaks_of_the_vote_box_are_the_peaks_of_the_whole_image(detector, views):
    model, cfg = detector.model, detector.config
    for view in views[:8]:
        accumulator = detector.votes(view.image)
        smoothed = smooth_votes(accumulator, cfg.smoothing_sigma_px)
        uv, _ = find_peaks(smoothed, model.peak_floor * model.vote_norm, cfg.nms_radius_px,
                           model.max_peaks)
        assert uv.shape[0] > 0
        np.testing.assert_array_equal(detector.peaks(view.image)[0], refine(accumulator, uv))


@pytest.mark.parametrize('sigma', [0.5, 1.3, 3.0, 4.7])
def test_smoothing_kernel_is_the_opencv_default(sigma):
    votes = np.random.default_rng(0).random((60, 80)).astype(np.float32)
    np.testing.assert_array_equal(
        smooth_votes(votes, sigma),
        cv2.GaussianBlur(votes, (0, 0), sigma, borderType=cv2.BORDER_CONSTANT))


def test_detections_are_well_formed(detector, views):
    cfg = detector.config
    for view in views[:6]:
        det = detector.detect(view.image)
        assert det.uv_px.shape[0] <= cfg.max_detections
        assert np.all((det.score >= cfg.min_score) & (det.score <= 1.0))
        assert np.all(np.diff(det.score) <= 0.0)
        assert np.all((det.uv_px >= 0.0) & (det.uv_px <= [319.0, 239.0]))


def test_skin_free_image_gives_no_detections(detector):
    image = np.zeros((240, 320, 3), np.uint8)
    image[...] = (40, 90, 200)
    assert detector.detect(image).uv_px.shape == (0, 2)


def test_fused_vote_kernel_matches_a_python_traversal(detector, views):
    model = detector.model
    forest = model.forest
    channels = compute_channels(views[0].image, model.skin_lut)
    ys, xs = candidates(gate_image(channels) >= model.gate, model.stride)
    pick = np.random.default_rng(0).choice(ys.size, 40, replace=False)
    ys, xs = ys[pick], xs[pick]
    weight, offset = forest.votes(model.radius_px)
    got = np.zeros((240, 320), np.float32)
    vote(channels, ys, xs, forest.roots, pack_nodes(forest, model.bank), weight, offset,
         0.0, got)
    expected = np.zeros((240, 320), np.float32)
    features = feature_matrix(channels, model.bank, ys, xs)
    for i in range(ys.size):
        for root in forest.roots:
            node = root
            while forest.left[node] != -1:
                go_left = features[i, forest.feature[node]] <= forest.threshold[node]
                node = forest.left[node] if go_left else forest.right[node]
            u = int(np.rint(xs[i] + offset[node, 0]))
            v = int(np.rint(ys[i] + offset[node, 1]))
            if 0 <= u < 320 and 0 <= v < 240:
                expected[v, u] += weight[node] * np.float32(1.0 / forest.roots.size)
    assert expected.sum() > 0.0
    np.testing.assert_allclose(got, expected, rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize('image', [np.zeros((240, 320), np.uint8),
                                   np.zeros((240, 320, 4), np.uint8),
                                   np.zeros((240, 320, 3), np.float32),
                                   [[0, 0, 0]]])
def test_wrong_image_raises(detector, image):
    with pytest.raises(ImageFormatError, match='image_rgb'):
        detector.detect(image)


def test_missing_model_file_raises(tmp_path):
    with pytest.raises(ConfigError, match='does not exist'):
        FingertipDetector.load(tmp_path / 'none.npz')


def test_model_file_lacking_a_field_raises(tmp_path):
    path = tmp_path / 'partial.npz'
    np.savez(path, bank=np.zeros((1, 6), np.int32))
    with pytest.raises(ConfigError, match='lacks'):
        DetectorModel.load(path)


def test_model_save_load_round_trip(detector, tmp_path):
    model = detector.model
    model.save(tmp_path / 'copy.npz')
    again = DetectorModel.load(tmp_path / 'copy.npz')
    np.testing.assert_array_equal(again.bank, model.bank)
    np.testing.assert_array_equal(again.forest.value, model.forest.value)
    np.testing.assert_array_equal(again.verifier.threshold, model.verifier.threshold)
    np.testing.assert_array_equal(again.verifier.value, model.verifier.value)
    np.testing.assert_array_equal(again.context.threshold, model.context.threshold)
    np.testing.assert_array_equal(again.context.value, model.context.value)
    assert (again.gate, again.stride, again.vote_norm, again.peak_floor, again.max_peaks) == (
        model.gate, model.stride, model.vote_norm, model.peak_floor, model.max_peaks)


def test_config_ranges_are_checked():
    with pytest.raises(ConfigError, match='min_score'):
        validate(DetectorConfig(min_score=1.5))
