"""The default finger proportions against the published measurements in docs/anthropometry.md."""
from __future__ import annotations

import numpy as np
import pytest

from hand_tracker_ros.model.shape import HandShape

# docs/anthropometry.md: Binvignat et al., sums of the phalangeal sectors, right hand, mm
# (thumb, index, middle, ring, little).
MEASURED_MM = {'men': (72.5, 104.2, 115.0, 109.1, 88.5), 'women': (63.5, 91.0, 100.4, 94.4, 75.8)}


def _model_phalanges() -> np.ndarray:
    lengths = HandShape().finger_lengths_m()
    # Thumb: proximal + distal (its first segment is the metacarpal); fingers: all three.
    return np.r_[lengths[0, 1:].sum(), lengths[1:].sum(axis=1)]


@pytest.mark.parametrize('group', sorted(MEASURED_MM))
def test_default_proportions_are_within_3_percent_of_the_measurements(group: str) -> None:
    measured = np.asarray(MEASURED_MM[group])
    model = _model_phalanges()
    ratio = (model / model[2]) / (measured / measured[2])
    np.testing.assert_allclose(ratio, 1.0, atol=0.03)


def test_the_documented_model_ratios_are_the_model_s() -> None:
    model = _model_phalanges()
    np.testing.assert_allclose(np.delete(model / model[2], 2), [0.638, 0.910, 0.957, 0.750],
                               atol=5e-4)
