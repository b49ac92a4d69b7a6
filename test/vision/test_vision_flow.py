from __future__ import annotations

import cv2
import numpy as np
import pytest

from hand_tracker_ros.errors import ImageFormatError, ShapeError
from hand_tracker_ros.vision.flow import DenseFlow, FlowConfig, FlowEstimator, SparseFlow

SHIFT_UV = (2.5, 1.5)


@pytest.fixture
def pair(rng, make_texture):
    """Factory: a textured gray frame and its affine warp ``curr(A p) = prev(p)``."""
    def make(warp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        prev = cv2.cvtColor(make_texture(rng, 240, 320), cv2.COLOR_RGB2GRAY)
        curr = cv2.warpAffine(prev, warp, (320, 240), flags=cv2.INTER_CUBIC,
                              borderMode=cv2.BORDER_REFLECT)
        return prev, curr
    return make


def _warps() -> dict[str, np.ndarray]:
    rotation = cv2.getRotationMatrix2D((160.0, 120.0), 3.0, 1.0)
    shift = np.array([[1.0, 0.0, SHIFT_UV[0]], [0.0, 1.0, SHIFT_UV[1]]])
    return {'shift': shift, 'rotation': rotation}


def _interior_grid(step: int = 4, margin: int = 30) -> np.ndarray:
    u, v = np.meshgrid(np.arange(margin, 320 - margin, step),
                       np.arange(margin, 240 - margin, step))
    return np.column_stack([u.ravel(), v.ravel()]).astype(float)


def _truth(warp: np.ndarray, uv: np.ndarray) -> np.ndarray:
    return uv @ warp[:, :2].T + warp[:, 2]


@pytest.mark.parametrize('motion, preset, max_median_epe_px', [
    ('shift', 'ultrafast', 0.2), ('shift', 'fast', 0.2),
    # A 3 deg rotation moves corners by ~10 px with a flow gradient of 0.05 px/px that
    # ultrafast's coarse patches (8 px, stride 6) only partly follow.
    ('rotation', 'ultrafast', 0.45), ('rotation', 'fast', 0.25)])
def test_dis_recovers_known_motion(pair, motion, preset, max_median_epe_px):
    warp = _warps()[motion]
    prev, curr = pair(warp)
    flow = FlowEstimator(FlowConfig(method='dis', dis_preset=preset)).compute(prev, curr)
    assert isinstance(flow, DenseFlow) and flow.flow_px.shape == (240, 320, 2)
    uv = _interior_grid()
    uv_curr, valid = flow.flow_at(uv)
    assert valid.all()
    epe = np.hypot(*(uv_curr - _truth(warp, uv)).T)
    assert np.median(epe) < max_median_epe_px


@pytest.mark.parametrize('motion', ['shift', 'rotation'])
def test_lk_tracks_recover_known_motion(pair, motion):
    warp = _warps()[motion]
    prev, curr = pair(warp)
    flow = FlowEstimator(FlowConfig(method='lk', lk_max_corners=200)).compute(prev, curr)
    assert isinstance(flow, SparseFlow)
    assert flow.pts_prev_px.shape[0] > 100
    epe = np.hypot(*(flow.pts_curr_px - _truth(warp, flow.pts_prev_px)).T)
    assert np.median(epe) < 0.1
    uv_curr, valid = flow.flow_at(flow.pts_prev_px.astype(float) + 0.5)
    assert valid.all()
    assert np.median(np.hypot(*(uv_curr - _truth(warp, flow.pts_prev_px + 0.5)).T)) < 0.1


def test_lk_forward_backward_check_drops_occluded_tracks(pair, make_texture):
    prev, curr = pair(_warps()['shift'])
    curr[:, 160:] = cv2.cvtColor(make_texture(np.random.default_rng(7), 240, 160),
                                 cv2.COLOR_RGB2GRAY)  # right half replaced: no true match
    flow = FlowEstimator(FlowConfig(method='lk', lk_max_corners=300)).compute(prev, curr)
    right = flow.pts_prev_px[:, 0] > 185
    epe = np.hypot(*(flow.pts_curr_px - _truth(_warps()['shift'], flow.pts_prev_px)).T)
    assert np.sum(~right) > 50
    assert np.median(epe[~right]) < 0.1
    assert np.sum(right) < 0.2 * np.sum(~right)


def test_dense_flow_at_is_exact_for_an_affine_field(rng):
    v, u = np.mgrid[0:30, 0:40].astype(np.float32)
    field = np.dstack([0.1 * u - 0.2 * v + 1.0, 0.05 * u + 0.3 * v - 2.0]).astype(np.float32)
    flow = DenseFlow(field)
    uv = np.column_stack([rng.uniform(0, 39, 500), rng.uniform(0, 29, 500)])
    uv = np.vstack([uv, [[39.0, 29.0], [0.0, 0.0], [39.5, 3.0], [-0.1, 3.0], [3.0, 30.0]]])
    uv_curr, valid = flow.flow_at(uv)
    np.testing.assert_array_equal(valid, [True] * 502 + [False] * 3)
    expected = uv + np.column_stack([0.1 * uv[:, 0] - 0.2 * uv[:, 1] + 1.0,
                                     0.05 * uv[:, 0] + 0.3 * uv[:, 1] - 2.0])
    np.testing.assert_allclose(uv_curr[valid], expected[valid], atol=1e-4)
    np.testing.assert_array_equal(uv_curr[~valid], uv[~valid])


def test_sparse_flow_attaches_each_track_to_its_nearest_query():
    prev = np.array([[10.0, 10.0], [10.5, 10.0], [30.0, 30.0]], np.float32)
    curr = prev + np.array([[2.0, 1.0], [9.0, 9.0], [-1.0, 0.0]], np.float32)
    flow = SparseFlow((50, 60), prev, curr, attach_radius_px=3.0)
    uv = np.array([[10.2, 10.0], [50.0, 40.0], [29.0, 30.0], [30.5, 30.0]])
    uv_curr, valid = flow.flow_at(uv)
    np.testing.assert_array_equal(valid, [True, False, False, True])
    np.testing.assert_allclose(uv_curr, [[12.2, 11.0], [50.0, 40.0], [29.0, 30.0],
                                         [29.5, 30.0]])
    empty = SparseFlow((50, 60), prev[:0], curr[:0], 3.0).flow_at(uv)
    assert not empty[1].any()


def test_flow_errors_and_determinism(pair):
    prev, curr = pair(_warps()['shift'])
    est = FlowEstimator(FlowConfig())
    with pytest.raises(ImageFormatError, match=r'one size, got \(240, 320\) and \(120, 320\)'):
        est.compute(prev, curr[:120])
    with pytest.raises(ImageFormatError, match=r'at least 16 px per side, got 100x10'):
        est.compute(prev[:10, :100], curr[:10, :100])
    a = est.compute(prev, curr).flow_px
    np.testing.assert_array_equal(a, FlowEstimator(FlowConfig()).compute(prev, curr).flow_px)
    # A non-contiguous ROI view is accepted (copied for DIS).
    roi = est.compute(prev[20:200, 30:250], curr[20:200, 30:250])
    assert roi.flow_px.shape == (180, 220, 2)
    with pytest.raises(ShapeError, match=r'`uv_prev_px` must be \(\*, 2\)'):
        DenseFlow(a).flow_at(np.zeros(4))
