"""Image terms over pose and shape: analytic Jacobian against central differences."""
from __future__ import annotations

import numpy as np
import pytest

from hand_tracker_ros.calibration.frame_terms import frame_terms
from hand_tracker_ros.core.frames import FrameSet
from hand_tracker_ros.energies.edges import EdgeEnergyConfig
from hand_tracker_ros.energies.registry import SIZE_TERMS
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.layout import P
from hand_tracker_ros.model.shape import HandShape
from hand_tracker_ros.pipeline.offline import OfflinePipeline, PipelineConfig
from hand_tracker_ros.synthetic.sequence import SynthConfig, SyntheticSequence


@pytest.fixture(scope='module')
def frame(hand_model: HandModel):
    """FrameTerms of one frame of a 1.1x hand, corresponded on the default model."""
    big = HandModel.build(HandShape(scale=1.1))
    sequence = SyntheticSequence(SynthConfig(motion='grasp', n_frames=12, n_cameras=3), big)
    shot = sequence.frame(8)
    pipeline = OfflinePipeline(hand_model, sequence.rig, PipelineConfig())
    observations = pipeline.observe(FrameSet(shot.stamp_ns, shot.images))[0]
    pipeline.close()
    return frame_terms(hand_model, sequence.rig.cameras, [observations], shot.theta[None])[0], \
        shot.theta


def test_every_image_term_has_rows(frame) -> None:
    terms, theta = frame
    assert {t.name for t in terms.fixed.terms} == set(SIZE_TERMS)
    # The edges of the outer silhouette only (module docstring); the tracker matches all.
    edges = next(t for t in terms.fixed.terms if t.name == 'edges')
    assert not edges.energy.config.inner_contours and EdgeEnergyConfig().inner_contours
    x = terms.model.shape.to_vector()
    squares = terms.squares(theta, x)
    assert all(squares[name][0] > 0.0 and squares[name][1] > 10 for name in ('edges',
                                                                            'silhouette'))


def test_jacobian_matches_central_differences(frame, numeric_jacobian) -> None:
    terms, theta = frame
    x = terms.model.shape.to_vector() * np.r_[1.03, 0.98, 1.02, np.full(15, 1.01), 0.97]
    z = np.r_[theta + 0.01, x]
    _, J = terms.residuals(z[:P], x, jacobian=True)
    num = numeric_jacobian(lambda zz: terms.residuals(zz[:P], zz[P:], jacobian=False)[0], z,
                           1e-7)
    assert J.shape == (num.shape[0], P + 19) and num.shape[0] > 100
    np.testing.assert_allclose(J, num, rtol=1e-5, atol=1e-5 * np.abs(num).max())
