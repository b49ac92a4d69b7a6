from __future__ import annotations

import cv2
import numpy as np
import pytest

from hand_tracker_ros.config import flatten, from_mapping
from hand_tracker_ros.errors import ConfigError, ImageFormatError, ShapeError
from hand_tracker_ros.vision.edges import edges_within
from hand_tracker_ros.vision.features import (
    CameraFeatures,
    FeatureExtractor,
    FeaturesConfig,
    MultiCameraFeatures,
)
from hand_tracker_ros.vision.flow import DenseFlow, FlowConfig, SparseFlow
from hand_tracker_ros.vision.visualize import paste_roi


def test_config_round_trips_through_dotted_parameters():
    cfg = from_mapping(FeaturesConfig, {'flow.method': 'lk', 'mask.method': 'background',
                                        'edges.canny_high': 120.0})
    assert cfg.flow.method == 'lk' and cfg.edges.canny_high == 120.0
    assert from_mapping(FeaturesConfig, flatten(cfg)) == cfg
    with pytest.raises(ConfigError, match=r'`flow.dis_preset` must be one of'):
        from_mapping(FeaturesConfig, {'flow.dis_preset': 'slow'})


def test_extractor_flow_lifecycle(scene):
    ex = FeatureExtractor('cam0', FeaturesConfig())
    first = ex.process(scene((60, 60))[0], 10)
    assert first.flow is None and first.camera_name == 'cam0' and first.stamp_ns == 10
    assert first.gray.shape == first.mask.shape == first.edges.edges.shape == (120, 160)
    second = ex.process(scene((63, 61))[0], 20)
    assert isinstance(second.flow, DenseFlow)
    # The blob moved by (3, 1): its centre's flow says so (DIS is coarse on a flat blob).
    uv_curr, valid = second.flow.flow_at(np.array([[60.0, 60.0]]))
    assert valid[0] and np.allclose(uv_curr[0], [63.0, 61.0], atol=1.0)
    assert ex.process(scene()[0][:100], 30).flow is None  # size change
    ex.reset()
    assert ex.process(scene()[0], 40).flow is None


def test_lk_extractor_tracks_inside_the_dilated_mask(scene):
    ex = FeatureExtractor('cam1', FeaturesConfig(flow=FlowConfig(method='lk'),
                                                 lk_mask_dilate_px=5))
    ex.process(scene((80, 60))[0], 0)
    flow = ex.process(scene((82, 60))[0], 1).flow
    assert isinstance(flow, SparseFlow) and flow.pts_prev_px.shape[0] > 0
    u, v = flow.pts_prev_px.T
    # Blob semi-axes (22, 32) + 5 px dilation + 1 px rounding.
    assert np.all(((u - 80) / 28) ** 2 + ((v - 60) / 38) ** 2 <= 1.0)


def test_lk_extractor_with_a_moving_roi(scene):
    ex = FeatureExtractor('cam2', FeaturesConfig(flow=FlowConfig(method='lk')))
    ex.process(scene((80, 60))[0], 0, roi_px=(30, 10, 130, 110))
    flow = ex.process(scene((82, 60))[0], 1, roi_px=(35, 12, 135, 112)).flow
    assert isinstance(flow, SparseFlow) and flow.pts_prev_px.shape[0] > 0
    assert flow.offset_uv_px == (35, 12)
    u, v = flow.pts_prev_px.T
    assert np.all((u >= 35) & (u < 135) & (v >= 12) & (v < 112))
    assert np.all(((u - 80) / 38) ** 2 + ((v - 60) / 48) ** 2 <= 1.0)  # 15 px dilation


def test_extractor_rejects_bad_images(scene):
    ex = FeatureExtractor('cam3', FeaturesConfig())
    with pytest.raises(ImageFormatError, match=r'cam3: expected an \(H, W, 3\) uint8 RGB'):
        ex.process(cv2.cvtColor(scene()[0], cv2.COLOR_RGB2GRAY), 0)


def test_multi_camera_matches_sequential_extractors(scene):
    images = [scene((50 + 10 * i, 60))[0] for i in range(3)]
    nxt = [scene((53 + 10 * i, 61))[0] for i in range(3)]
    cfg = FeaturesConfig()
    names = ('a', 'b', 'c')
    with MultiCameraFeatures(names, cfg) as multi:
        multi.process(images, 1)
        out = multi.process(nxt, [2, 3, 4])
    assert [f.camera_name for f in out] == list(names)
    assert [f.stamp_ns for f in out] == [2, 3, 4]
    for name, img0, img1, got in zip(names, images, nxt, out):
        ex = FeatureExtractor(name, cfg)
        ex.process(img0, 1)
        ref = ex.process(img1, 0)
        np.testing.assert_array_equal(got.edges.edges, ref.edges.edges)
        np.testing.assert_array_equal(got.mask, ref.mask)
        np.testing.assert_array_equal(got.flow.flow_px, ref.flow.flow_px)


def test_multi_camera_argument_errors(scene):
    with pytest.raises(ConfigError, match='non-empty and distinct'):
        MultiCameraFeatures(('a', 'a'), FeaturesConfig())
    with MultiCameraFeatures(('a', 'b'), FeaturesConfig()) as multi:
        with pytest.raises(ShapeError, match=r'expected 2 images, stamps, masks and rois'):
            multi.process([scene()[0]], 0)


def test_roi_features_use_full_image_coordinates(scene, rng):
    cfg = FeaturesConfig()  # skin mask, DIS flow
    full = FeatureExtractor('full', cfg).process(scene((80, 60))[0], 0)
    ex = FeatureExtractor('roi', cfg)
    ex.process(scene((80, 60))[0], 0, roi_px=(40, 20, 120, 100))
    # The box moves with the blob, and is clipped at the image border.
    out = ex.process(scene((82, 61))[0], 1, roi_px=(42, 21, 122, 200))
    assert out.roi_px == (42, 21, 122, 120) and out.image_size_px == (160, 120)
    assert out.mask.shape == out.gray.shape == out.edges.shape == (99, 80)
    assert out.edges.offset_uv_px == (42, 21) and out.flow.offset_uv_px == (42, 21)
    # Edge lookup agrees with the full-image map well inside the box.
    uv = np.column_stack([rng.uniform(60, 100, 300), rng.uniform(40, 80, 300)])
    full_next = FeatureExtractor('full', cfg).process(scene((82, 61))[0], 1)
    got, ref = edges_within(out.edges, uv, 6.0), edges_within(full_next.edges, uv, 6.0)
    assert 0.1 < np.mean(ref) < 0.9 and np.mean(got == ref) > 0.95
    # Flow of the blob centre, queried in full-image coordinates.
    uv_curr, valid = out.flow.flow_at(np.array([[80.0, 60.0]]))
    assert valid[0] and np.allclose(uv_curr[0], [82.0, 61.0], atol=1.0)
    # mask_at: inside the blob, outside it, and outside the ROI.
    np.testing.assert_array_equal(out.mask_at(np.array([[82.0, 61.0], [45.0, 25.0],
                                                        [10.0, 10.0]])), [True, False, False])
    assert full.mask_at(np.array([[80.0, 60.0]]))[0]
    pasted = paste_roi(out.mask, out.roi_px, out.image_size_px, fill=False)
    assert pasted.shape == (120, 160) and pasted[61, 82] and not pasted[:21].any()


def test_roi_outside_the_image_is_rejected(scene):
    with pytest.raises(ImageFormatError,
                       match=r'cam0: roi_px \(200, 0, 300, 50\) does not overlap the 160x120'):
        FeatureExtractor('cam0', FeaturesConfig()).process(scene()[0], 0,
                                                           roi_px=(200, 0, 300, 50))


def test_silhouette_pixels_from_the_foreground_box_equal_the_whole_roi_form():
    rng = np.random.default_rng(4)
    for trial in range(10):
        mask = np.zeros((60, 80), np.uint8)
        for _ in range(2):   # blobs that may cross the ROI border, which is not background
            cv2.circle(mask, tuple(int(c) for c in rng.integers(-5, 85, 2)),
                       int(rng.integers(3, 20)), 1, -1)
        roi = (10 + trial, 5, 90 + trial, 65)
        features = CameraFeatures('c', 0, None, mask.astype(bool), None, mask, roi, (160, 120))
        inner = cv2.erode(mask, cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3)))
        rows, cols = np.nonzero(mask > inner)
        np.testing.assert_array_equal(features.silhouette_px,
                                      np.column_stack([cols + roi[0], rows + roi[1]]))
    empty = CameraFeatures('c', 0, None, np.zeros((60, 80), bool), None, mask, roi, (160, 120))
    assert empty.silhouette_px.shape == (0, 2)


def test_mask_at_matches_the_numpy_form():
    rng = np.random.default_rng(6)
    mask = rng.random((60, 80)) < 0.5
    roi = (30, 20, 110, 80)
    features = CameraFeatures('c', 0, None, mask, None, None, roi, (160, 120))
    uv = np.vstack([rng.uniform(20, 120, (2000, 2)),
                    np.array([[29.5, 20.0], [30.5, 20.0], [109.5, 79.5], [110.5, 40.0]])])
    col = np.rint(uv[:, 0]).astype(np.int64) - roi[0]
    row = np.rint(uv[:, 1]).astype(np.int64) - roi[1]
    inside = (col >= 0) & (col < 80) & (row >= 0) & (row < 60)
    ref = np.zeros(len(uv), bool)
    ref[inside] = mask[row[inside], col[inside]]
    np.testing.assert_array_equal(features.mask_at(uv), ref)
