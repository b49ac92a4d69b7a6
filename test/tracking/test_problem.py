"""The stacked objective skins with the Jacobian only the vertices its rows read."""
from __future__ import annotations

import math

import numpy as np

import hand_tracker_ros.tracking.tracker as tracker_module
from hand_tracker_ros.core.frames import FrameSet
from hand_tracker_ros.model.layout import PARAM_NAMES
from hand_tracker_ros.pipeline.offline import OfflinePipeline, PipelineConfig
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence
from hand_tracker_ros.tracking.problem import Problem
from hand_tracker_ros.tracking.schedule import ScheduleConfig


def _rounds_of_one_frame(hand_model, monkeypatch):
    """(problem, correspondences) of every round of one tracked frame."""
    sequence = SyntheticSequence(SynthConfig(motion='grasp', n_frames=2), hand_model)
    frames = [sequence.frame(k) for k in range(2)]
    pipeline = OfflinePipeline(hand_model, sequence.rig, PipelineConfig())
    pipeline.session.reset(frames[0].theta)
    pipeline.observe(FrameSet(frames[0].stamp_ns, frames[0].images))
    captured = []
    solve = tracker_module.HandTracker._solve_round

    def spy(self, *args, **kwargs):
        out = solve(self, *args, **kwargs)
        captured.append((out[2], out[3], out[0]))
        return out

    monkeypatch.setattr(tracker_module.HandTracker, '_solve_round', spy)
    pipeline.step(FrameSet(frames[1].stamp_ns, frames[1].images))
    pipeline.close()
    return captured


def _full_jacobian(problem, correspondences, theta):
    posed = problem.model.pose(theta)   # every row of vertices_jac
    return np.vstack([math.sqrt(t.weight) * t.energy.linearize(posed, c)[1]
                      for t, c in zip(problem.terms, correspondences)])


def test_restricted_skinning_gives_the_full_jacobian(hand_model, monkeypatch) -> None:
    rounds = _rounds_of_one_frame(hand_model, monkeypatch)
    schedule = ScheduleConfig()
    assert len(rounds) == schedule.coarse_rounds + schedule.full_rounds
    for problem, correspondences, theta in rounds:
        r, J = problem.function(correspondences)(theta, True)
        assert r.size > 100
        np.testing.assert_array_equal(J, _full_jacobian(problem, correspondences, theta))
    # Collision rows read the vertices of the receiving triangles too.
    problem, correspondences, _ = rounds[-1]
    theta = hand_model.neutral_theta()
    theta[PARAM_NAMES.index('index_mcp_abd')] = -0.3
    collision = next(t for t in problem.terms if t.name == 'collision')
    pairs = collision.energy.pairs_at(hand_model.pose(theta, jacobian=False).vertices_m)
    assert pairs.n_residuals > 0
    alone = Problem(hand_model, [collision])
    _, J = alone.function([pairs])(theta, True)
    np.testing.assert_array_equal(J, _full_jacobian(alone, [pairs], theta))


def test_pose_restricted_to_vertices_leaves_other_rows_zero(hand_model) -> None:
    theta = hand_model.neutral_theta()
    rows = np.array([3, 17, 400])
    full = hand_model.pose(theta)
    part = hand_model.pose(theta, jacobian_vertices=rows)
    np.testing.assert_array_equal(part.vertices_m, full.vertices_m)
    np.testing.assert_array_equal(part.vertices_jac[rows], full.vertices_jac[rows])
    others = np.setdiff1d(np.arange(hand_model.rest_vertices_m.shape[0]), rows)
    assert not part.vertices_jac[others].any()
