"""The evaluation: metrics by formula, and the ablation command end to end on tiny data."""
from __future__ import annotations

import json

import numpy as np
import pytest

from hand_tracker_ros.cli.main import main
from hand_tracker_ros.evaluation.metrics import joint_errors_mm, score_sequence
from hand_tracker_ros.geometry.rig import CameraRig


def test_metrics_follow_their_formulas() -> None:
    truth = np.zeros((3, 21, 3))
    estimate = truth.copy()
    estimate[1, :, 0] = 0.002          # frame 1: every keypoint 2 mm off
    estimate[2, 4, 0] = 0.021          # frame 2: one tip 21 mm off -> 1 mm mean
    np.testing.assert_allclose(joint_errors_mm(estimate, truth), [0.0, 2.0, 1.0])
    rig = CameraRig.ring(2)
    scores = score_sequence(estimate, truth, [False, False, True], rig.cameras,
                            [0.0, 0.0005, 0.0], [0.01, 0.02, 0.03])
    assert scores.joint_mean_mm == pytest.approx(1.0)
    assert scores.joint_max_mm == pytest.approx(2.0)
    assert scores.fingertip_mean_mm == pytest.approx((0 + 2 + 21 / 5) / 3)
    assert scores.failures == 1 and scores.ms_per_frame == pytest.approx(20.0)
    assert scores.max_interpenetration_mm == pytest.approx(0.5)


@pytest.mark.slow
def test_evaluate_writes_tables_and_plot(tmp_path) -> None:
    out = tmp_path / 'eval'
    assert main(['evaluate', '--out', str(out), '--frames', '6', '--motions', 'grasp',
                 '--configs', 'LO+E', 'full', '--no-tradeoff', '--workers', '1']) == 0
    summary = json.loads((out / 'ablation.json').read_text())['summary']
    assert set(summary) == {'LO+E', 'full'}
    assert 0.0 < summary['full']['joint_mean_mm'] < 15.0
    assert '| full |' in (out / 'ablation.md').read_text()
    assert (out / 'ablation_error.png').stat().st_size > 1000
