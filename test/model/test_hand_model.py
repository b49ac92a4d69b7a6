"""HandModel public API: validation, neutral pose, caching, shape vectors."""
from __future__ import annotations

import numpy as np
import pytest

from hand_tracker_ros.errors import ConfigError, ShapeError
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.model.layout import PARAM_NAMES
from hand_tracker_ros.model.shape import SHAPE_NAMES, HandShape


def test_neutral_pose_within_limits(model: HandModel) -> None:
    theta = model.neutral_theta(translation_m=(0.0, 0.0, 0.5))
    assert np.all(theta >= model.lower) and np.all(theta <= model.upper)
    assert theta[2] == 0.5 and np.all(theta[6:][np.array(
        [n.endswith('flex') for n in PARAM_NAMES[6:]])] > 0.0)


def test_limits_table(model: HandModel) -> None:
    assert np.all(model.lower < model.upper)
    assert model.upper[0] == 5.0 and model.lower[3] == pytest.approx(-2 * np.pi)
    assert model.upper[PARAM_NAMES.index('index_pip_flex')] == pytest.approx(np.deg2rad(110))


@pytest.mark.parametrize('theta', [np.zeros(25), np.zeros((26, 1))])
def test_pose_rejects_wrong_shape(model: HandModel, theta: np.ndarray) -> None:
    with pytest.raises(ShapeError, match='`theta` must be'):
        model.pose(theta)


def test_pose_rejects_non_finite(model: HandModel) -> None:
    theta = np.zeros(26)
    theta[7] = np.nan
    with pytest.raises(ShapeError, match='non-finite'):
        model.pose(theta)


def test_pose_without_jacobian(model: HandModel) -> None:
    posed = model.pose(model.neutral_theta(), jacobian=False)
    assert posed.vertices_jac is None and posed.keypoints_jac is None
    assert posed.sphere_centers_jac is None
    assert posed.vertices_m.shape == model.rest_vertices_m.shape
    assert posed.sphere_centers_m.shape == (model.sphere_radii_m.size, 3)


def test_model_is_cached_and_read_only(model: HandModel) -> None:
    assert HandModel.build(HandShape()) is model
    with pytest.raises(ValueError):
        model.rest_vertices_m[0, 0] = 1.0


def test_shape_vector_round_trip() -> None:
    shape = HandShape(scale=0.9, palm_width_m=0.05, ring_m=(0.05, 0.03, 0.02))
    vec = shape.to_vector()
    assert vec.shape == (len(SHAPE_NAMES),) == (19,)
    assert HandShape.from_vector(vec) == shape
    with pytest.raises(ShapeError):
        HandShape.from_vector(vec[:-1])


def test_shape_rejects_non_positive() -> None:
    with pytest.raises(ConfigError, match='palm_width_m'):
        HandShape(palm_width_m=0.0)


def test_sphere_mesh_tables(model: HandModel) -> None:
    s = model.sphere_radii_m.size
    assert model.pills.max() < s and model.wedges.max() < s
    assert model.pills.shape == (15, 2) and model.wedges.shape[1] == 3
    assert np.all(model.sphere_part[model.wedges] == 0)
