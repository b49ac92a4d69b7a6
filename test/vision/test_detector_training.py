from __future__ import annotations

import argparse

import numpy as np
import pytest
from sklearn.ensemble import HistGradientBoostingClassifier, RandomForestRegressor

from hand_tracker_ros.cli import train_detector
from hand_tracker_ros.errors import ConfigError
from hand_tracker_ros.vision.detector.channels import (compute_channels, feature_matrix,
                                                       random_bank)
from hand_tracker_ros.vision.detector.data import labelled_views
from hand_tracker_ros.vision.detector.forest import predict
from hand_tracker_ros.vision.detector.model import DetectorModel
from hand_tracker_ros.vision.detector.training import (TrainingConfig, export_boosted,
                                                         export_forest, train)

TINY = TrainingConfig(n_views=6, n_trees=3, max_leaves=60, n_features=64,
                      positives_per_tip=10, negatives_per_view=60, calibration_views=2,
                      n_jobs=1, verifier_views=6, verifier_trees=2, verifier_max_leaves=20,
                      context_iterations=5, context_max_leaves=8)


def _nodes(forest):
    return (forest.roots, forest.left, forest.right, forest.feature, forest.threshold,
            forest.value)


def test_numba_forest_equals_sklearn_predict(hand_model):
    rng = np.random.default_rng(3)
    views = list(labelled_views(2, seed=11, model=hand_model))
    lut = np.full((64, 64), 128, dtype=np.uint8)
    bank = random_bank(48, 12, 0.7, rng)
    blocks = [feature_matrix(compute_channels(v.image, lut), bank,
                             rng.integers(0, 240, 300), rng.integers(0, 320, 300))
              for v in views]
    x = np.concatenate(blocks)
    # A target that depends on the features, so the trees really split.
    y = np.column_stack([x[:, 0] > np.median(x[:, 0]), x[:, 1] / 255.0,
                         np.sin(x[:, 2] / 40.0)]).astype(np.float64)
    forest = RandomForestRegressor(n_estimators=4, max_leaf_nodes=40, random_state=0)
    forest.fit(x.astype(np.float32), y)
    exported = export_forest(forest.estimators_)
    assert exported.left.size > 4 * 20
    ours = predict(_nodes(exported), x)
    np.testing.assert_allclose(ours, forest.predict(x.astype(np.float32)), rtol=0, atol=1e-12)


def test_numba_boosted_trees_equal_sklearn_decision_function():
    rng = np.random.default_rng(4)
    x = rng.normal(size=(600, 6)).astype(np.float32)
    y = (x[:, 0] + 0.5 * x[:, 1] ** 2 + 0.3 * rng.normal(size=600) > 0.4).astype(int)
    boosted = HistGradientBoostingClassifier(max_iter=15, max_leaf_nodes=7,
                                             early_stopping=False, random_state=0).fit(x, y)
    exported = export_boosted(boosted)
    assert exported.roots.size == 15 and exported.value.shape[1] == 1
    logit = predict(_nodes(exported), x)[:, 0]
    np.testing.assert_allclose(logit, boosted.decision_function(x), rtol=0, atol=1e-9)
    np.testing.assert_allclose(1.0 / (1.0 + np.exp(-logit)), boosted.predict_proba(x)[:, 1],
                               rtol=0, atol=1e-9)


@pytest.mark.slow
def test_training_is_deterministic(hand_model, tmp_path):
    paths = []
    for name, seed in (('a', 5), ('b', 5), ('c', 6)):
        train(seed, TINY, model=hand_model).save(tmp_path / f'{name}.npz')
        paths.append(tmp_path / f'{name}.npz')
    a, b, c = (p.read_bytes() for p in paths)
    assert a == b
    assert a != c
    model = DetectorModel.load(paths[0])
    assert model.seed == 5 and model.forest.roots.size == TINY.n_trees
    assert 0 < model.gate < 255 and model.vote_norm > 0.0
    assert model.verifier.roots.size == TINY.verifier_trees
    assert model.verifier.value.shape[1] == 1
    assert 1 <= model.context.roots.size <= TINY.context_iterations
    assert model.context.value.shape[1] == 1


def test_cli_writes_a_loadable_model(tmp_path, capsys):
    out = tmp_path / 'm.npz'
    args = argparse.Namespace(seed=1, out=str(out), views=3, trees=2, verifier_views=3)
    assert train_detector.run(args) == 0
    assert 'wrote' in capsys.readouterr().out
    model = DetectorModel.load(out)
    assert model.forest.roots.size == 2
    assert model.verifier.roots.size == TrainingConfig().verifier_trees


def test_cli_rejects_bad_options(tmp_path):
    args = argparse.Namespace(seed=1, out=str(tmp_path / 'm.npz'), views=0, trees=2,
                              verifier_views=3)
    with pytest.raises(ConfigError, match='n_views'):
        train_detector.run(args)
