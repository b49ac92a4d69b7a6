r"""Training of the fingertip detector: Hough forest and peak verifier (needs scikit-learn;
the runtime does not).

Steps, all deterministic in the seed:

1. render ``n_views`` labelled views (:mod:`.data`);
2. learn the skin table from chroma histograms of hand pixels vs all pixels, and the
   candidate gate as the ``gate_quantile`` of the skin likelihood of positive pixels;
3. sample gated pixels per view: positives within ``radius_px`` of a visible tip (at most
   ``positives_per_tip``), negatives farther than ``radius_px`` from every tip (half on the
   hand, half elsewhere), pixels near only invisible tips are left out (ambiguous labels);
4. describe them with a random bank of pixel tests and fit a scikit-learn random forest
   *regressor* on the targets :math:`(y, y\,d_x/R, y\,d_y/R)`: its squared-error split
   criterion sums the class impurity and the offset variance of the positives, the two
   uncertainties a Hough forest alternates between, in one objective;
5. bootstrap (hard-negative mining): run the first forest on every candidate of the
   training views, add up to ``hard_negatives_per_view`` negatives it scores highest
   (tip probability >= ``hard_min_weight``: skin-coloured clutter corners, knuckles, finger
   bends) and refit on the union;
6. export the trees to flat arrays and calibrate ``vote_norm`` (median vote peak at visible
   tips on a subset of the training views);
7. render ``verifier_views`` views of scenes the forest never saw, run the detector up to
   its vote peaks (at most ``max_peaks`` above ``peak_floor * vote_norm``), label each peak
   1 within ``verify_radius_px`` of a visible tip and 0 farther than that from every tip
   (peaks near only invisible tips are left out), and fit the verifier forest on their
   :func:`.verifier.peak_features`. Fresh scenes matter: on its own training views the
   forest's peaks are cleaner than on new images, and the verifier must learn the latter.
8. fit the context verifier, gradient-boosted trees (scikit-learn's
   ``HistGradientBoostingClassifier``, early stopping on 10% of the peaks), on the same
   peaks, their features followed by :func:`.verifier.context_features` of the first
   verifier's out-of-bag scores (:func:`fit_verifiers`).

Forest defaults come from a small ablation (400 training views, one fit, average precision
of "tip within R" over all candidates of 60 held-out views): 256 tests in a +-16 px window
0.25; 5 x 5-averaged skin channel 0.29; plus 512 tests 0.32; window +-12 px 0.37, +-9 px
0.40, +-6 px 0.42. Larger trees (20000 leaves) lowered it (0.23 vs 0.25): the limit is data
and features, not capacity, so leaves are capped to keep the model file small.

Detector-level ablation (400 forest views, detection precision / recall within 8 px on 150
views of the bench's held-out seed):

- forest only, score = vote height (the previous detector), min_score 0.4 / 0.5 / 0.6:
  0.75 / 0.76, 0.80 / 0.72, 0.86 / 0.63. Diagnosis on the shipped model (300 views): of
  344 false positives 183 lay on the hand far from any tip (knuckles, finger bends, the
  wrist end), 91 on background clutter (skin-coloured stripes, line ends), 64 at 8-16 px
  from a tip, 6 were duplicates; of 249 missed tips most had a weak peak (score 0.2-0.4
  or none) and ~90 a peak that lost the top-5 cut to false positives. Missed tips had more
  hand around them than found ones (tips over the palm or other fingers).
- changes to the forest that did not help (same protocol, min_score 0.4): extra channels
  (Sobel luma gradient, 15 x 15 skin average, skin distance transform) 0.76 / 0.76;
  multi-scale test windows (3, 6, 12 px) 0.76 / 0.72; +-4 px window 0.71 / 0.77; offsets
  weighted 0.25 in the split criterion 0.71 / 0.77 (same trade-off curves within 0.02).
- verifier on the forest's peaks (800 fresh views), min_score 0.4: peak height features
  only 0.81 / 0.69 (no better than the vote height); plus ring profiles 0.87 / 0.72 (0.81 /
  0.75 at 0.3). Distance to the palm centre, vote-shape sums, 256 extra pixel tests in a
  +-12 px window, 3x the verifier views, a lower peak floor (0.05, 30 peaks) or gradient
  boosting instead of a forest all stayed within 0.015.
- end to end, min_score 0.4, 400 + 800 views: stride 3 0.85 / 0.73, stride 4 0.85 / 0.71.
  Full recipe (1200 + 1200 views), all 300 bench views, min_score 0.4: 10 trees stride 4
  0.820 / 0.697 (4.9 ms/frame on the shared 2-core machine); 10 trees stride 3 0.835 /
  0.721 (5.9 ms; 0.782 / 0.758 at min_score 0.3, where the old detector had 0.71 / 0.77 at
  0.4); 5 trees stride 3 (the default: half the vote time) 0.819 / 0.700, 3.5 ms
  (0.766 / 0.742 at min_score 0.3).
  Ranking the same forest's peaks (10 trees, stride 4) by vote height instead of by the
  verifier gives 0.05-0.07 lower precision at equal recall on either half of the 300 views.
- context verifier (issue 4; all 300 bench views, default recipe, min_score 0.4): 0.845 /
  0.730 vs 0.819 / 0.700 without (0.809 / 0.765 at 0.3); with the neighbour, 40 px and
  rim-distance context features 0.842 / 0.744 (0.877 / 0.708 at 0.5, 0.905 / 0.662 at
  0.6), and 0.851 / 0.739 (0.882 / 0.702, 0.907 / 0.655) for the same recipe after
  last-bit changes of the forward kinematics elsewhere in the tree: tied forest splits
  flip, so +-0.01 is run-to-run spread, not signal (the same tree gives the same bytes).
  Twice the verifier views (2400) changed it by less than 0.01. Diagnosis before it: the
  forest's top-20 peaks hold a peak within 8 px of 92% of visible tips (75% within 4 px),
  so scoring, not candidates, loses most tips; nearest-peak scores fall with the peak's
  distance to its tip (>= 0.4 for 90% of peaks within 2 px, 52% at 4-6 px). Things that
  did not help the verifier (same peaks, min_score 0.4-0.6): 100 trees of 2000 leaves,
  max_features 0.6, raw ring samples rotated to the finger direction (288 more
  features); smoothing sigma 2 / NMS 3 px (97% of tips with a peak within 8 px, but
  precision at equal recall 0.01-0.02 lower); an offset regressor moving each peak
  towards its tip (peaks within 4 px 75% -> 77%).
- verifier selection on cached peaks (issue 4; the shipped forest's peaks on 1200 fresh
  views of seed 0 for training, 400 views of seed 1 for validation; P / R at min_score
  0.4 / 0.5 / 0.6): the random-forest context verifier 0.807 / 0.734, 0.851 / 0.705,
  0.883 / 0.658 (0.806 / 0.738, 0.848 / 0.697, 0.890 / 0.650 with another forest seed);
  a gradient-boosted context verifier 0.815 / 0.744, 0.854 / 0.710, 0.888 / 0.666; plus
  the shape and edge features of :mod:`.shape` 0.831 / 0.747, 0.862 / 0.729, 0.881 /
  0.704 (the random forest with them 0.819 / 0.740, 0.853 / 0.695, 0.892 / 0.656).
  No gain: verifier features at 3 x 3 sub-positions 2 px apart with the highest score
  taken (0.819 / 0.729 at 0.4), also moving the peak there (0.810 / 0.716), or with
  positives within 3 px only (0.806 / 0.692); raw 13 x 13 patches of luma, skin and gate
  mask (boosting 0.782 / 0.747, an MLP 0.817 / 0.709); boosting for both verifiers with
  2-fold cross-fitted context scores (0.789 / 0.747; averaged with the forests 0.825 /
  0.751, 0.869 / 0.722, 0.899 / 0.679, four models for ~0.01).
  Shipped model with the boosted context verifier and the shape terms (``train-detector
  --seed 0``, 367 s; all 300 bench views, run once): 0.856 / 0.754 at min_score 0.4
  (was 0.851 / 0.739), 0.903 / 0.708 at 0.6 (0.907 / 0.655), 0.796 / 0.798 at 0.2
  (0.756 / 0.793); the shape terms cost ~1 ms per frame on the loaded 2-core machine.
"""
from __future__ import annotations

import dataclasses
import logging
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from hand_tracker_ros._typing import FloatArray, IntArray, UInt8Array
from hand_tracker_ros.config import param
from hand_tracker_ros.model.hand import HandModel
from hand_tracker_ros.vision.detector.channels import (
    SKIN_BINS, candidates, chroma_histogram, compute_channels, feature_matrix, gate_image,
    random_bank, skin_table)
from hand_tracker_ros.vision.detector.data import LabelledView, labelled_views
from hand_tracker_ros.vision.detector.detector import (DetectorConfig, FingertipDetector,
                                                       smooth_votes)
from hand_tracker_ros.vision.detector.forest import ForestArrays, predict
from hand_tracker_ros.vision.detector.model import DetectorModel
from hand_tracker_ros.vision.detector.verifier import context_features

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class TrainingConfig:
    """Fingertip forest training."""

    n_views: int = param(1200, 'rendered training views', low=1, high=1_000_000)
    n_trees: int = param(5, 'trees of the forest', low=1, high=200)
    max_leaves: int = param(3000, 'leaves per tree (bounds the model size)', low=2,
                            high=1_000_000)
    min_samples_leaf: int = param(5, 'minimum training samples per leaf', low=1, high=10000)
    n_features: int = param(512, 'pixel tests in the random bank', low=1, high=4096)
    max_features: float = param(0.08, 'fraction of the bank tried at each split', low=0.0,
                                high=1.0)
    window_px: int = param(6, 'half-size of the test window', unit='px', low=1, high=64)
    pair_fraction: float = param(0.75, 'fraction of two-pixel tests', low=0.0, high=1.0)
    radius_px: float = param(7.0, 'a candidate within this distance of a tip is positive',
                             unit='px', low=1.0, high=30.0)
    positives_per_tip: int = param(40, 'positive samples per visible tip and view', low=1,
                                   high=10000)
    negatives_per_view: int = param(300, 'negative samples per view', low=0, high=100000)
    gate_quantile: float = param(0.02, 'fraction of positive pixels the candidate gate may '
                                 'lose', low=0.0, high=0.5)
    hard_negatives_per_view: int = param(
        150, 'hard negatives mined per view for the second fit (0: a single fit)', low=0,
        high=100000)
    hard_min_weight: float = param(0.2, 'a negative candidate is hard when the first forest '
                                   'gives it at least this tip probability', low=0.0,
                                   high=1.0)
    stride: int = param(3, 'candidate grid step at inference', unit='px', low=1, high=8)
    calibration_views: int = param(100, 'training views used to calibrate vote_norm', low=1,
                                   high=100000)
    verifier_views: int = param(1200, 'views (scenes the forest never saw) whose vote peaks '
                                'train the verifier', low=1, high=1_000_000)
    verifier_trees: int = param(20, 'trees of the verifier', low=1, high=200)
    verifier_max_leaves: int = param(400, 'leaves per verifier tree', low=2, high=1_000_000)
    verifier_min_samples_leaf: int = param(3, 'minimum verifier samples per leaf', low=1,
                                           high=10000)
    verifier_max_features: float = param(0.3, 'fraction of the peak features tried at each '
                                         'verifier split', low=0.0, high=1.0)
    context_iterations: int = param(200, 'most boosting iterations (trees) of the context '
                                    'verifier; early stopping on 10% of its peaks may use '
                                    'fewer', low=1, high=10000)
    context_learning_rate: float = param(0.1, 'learning rate of the boosted context verifier',
                                         low=1e-4, high=1.0)
    context_max_leaves: int = param(31, 'leaves per context verifier tree', low=2,
                                    high=100000)
    verify_radius_px: float = param(8.0, 'a peak within this distance of a visible tip is a '
                                    'positive verifier sample', unit='px', low=1.0, high=30.0)
    peak_floor: float = param(0.1, 'vote peaks below peak_floor * vote_norm are not verified',
                              low=0.0, high=1.0)
    max_peaks: int = param(20, 'highest vote peaks per image that are verified', low=1,
                           high=1000)
    n_jobs: int = param(2, 'scikit-learn worker threads (results do not depend on it)', low=1,
                        high=64)


def _tip_distances(shape_hw: tuple[int, int], view: LabelledView) -> tuple[FloatArray, ...]:
    """Per-pixel distance to the nearest visible / invisible tip and offset to the visible."""
    vs, us = np.mgrid[0:shape_hw[0], 0:shape_hw[1]].astype(np.float64)
    tips = np.nan_to_num(view.tips_uv, nan=-1e6)
    dist = np.hypot(us[None] - tips[:, 0, None, None], vs[None] - tips[:, 1, None, None])
    vis = np.where(view.tips_visible[:, None, None], dist, np.inf)
    hid = np.where(view.tips_visible[:, None, None], np.inf, dist)
    nearest = np.argmin(vis, axis=0)
    return (vis.min(axis=0), hid.min(axis=0), tips[nearest, 0] - us, tips[nearest, 1] - vs)


def _sample_view(view: LabelledView, channels: UInt8Array, gate: int, cfg: TrainingConfig,
                 rng: np.random.Generator) -> tuple[IntArray, IntArray, FloatArray]:
    """Sampled pixels (ys, xs) and their targets (N, 3) of one view."""
    d_vis, d_hid, dx, dy = _tip_distances(view.hand_mask.shape, view)
    gated = gate_image(channels) >= gate
    positive = gated & (d_vis <= cfg.radius_px)
    negative = gated & (d_vis > cfg.radius_px) & (d_hid > cfg.radius_px)
    n_pos = cfg.positives_per_tip * int(view.tips_visible.sum())
    half = cfg.negatives_per_view // 2
    picks = [_pick(positive, n_pos, rng), _pick(negative & view.hand_mask, half, rng),
             _pick(negative & ~view.hand_mask, cfg.negatives_per_view - half, rng)]
    ys = np.concatenate([p[0] for p in picks])
    xs = np.concatenate([p[1] for p in picks])
    label = positive[ys, xs].astype(np.float64)
    targets = np.column_stack([label, label * dx[ys, xs] / cfg.radius_px,
                               label * dy[ys, xs] / cfg.radius_px])
    return ys, xs, targets


def _pick(mask: np.ndarray, n: int, rng: np.random.Generator) -> tuple[IntArray, IntArray]:
    ys, xs = np.nonzero(mask)
    keep = rng.permutation(ys.size)[:n]
    return ys[np.sort(keep)], xs[np.sort(keep)]


def _skin_model(views: list[LabelledView], quantile: float,
                radius_px: float) -> tuple[UInt8Array, int]:
    """Skin table and candidate gate learned from the views."""
    flat = np.full((SKIN_BINS, SKIN_BINS), 128, dtype=np.uint8)
    hand = np.zeros((SKIN_BINS, SKIN_BINS))
    total = np.zeros((SKIN_BINS, SKIN_BINS))
    for view in views:
        channels = compute_channels(view.image, flat)
        hand += chroma_histogram(channels, view.hand_mask)
        total += chroma_histogram(channels, np.ones_like(view.hand_mask))
    lut = skin_table(hand, total)
    near = []
    for view in views:
        channels = compute_channels(view.image, lut)
        d_vis = _tip_distances(view.hand_mask.shape, view)[0]
        near.append(gate_image(channels)[(d_vis <= radius_px) & view.hand_mask])
    gate = int(np.floor(np.quantile(np.concatenate(near), quantile)))
    return lut, max(gate, 1)


def export_forest(estimators: list) -> ForestArrays:
    """Concatenate fitted scikit-learn regression trees into :class:`ForestArrays`."""
    roots, left, right, feature, threshold, value = [], [], [], [], [], []
    offset = 0
    for estimator in estimators:
        tree = estimator.tree_
        internal = tree.children_left >= 0
        roots.append(offset)
        left.append(np.where(internal, tree.children_left + offset, -1))
        right.append(np.where(internal, tree.children_right + offset, -1))
        feature.append(np.where(internal, tree.feature, -1))
        threshold.append(tree.threshold)
        value.append(tree.value[:, :, 0])
        offset += tree.node_count
    return _concatenated(roots, left, right, feature, threshold, value)


def _regression_forest(features: np.ndarray, targets: FloatArray, n_trees: int,
                       max_leaves: int, min_samples_leaf: int, max_features: float, seed: int,
                       n_jobs: int, oob: bool = False):
    """A bootstrapped scikit-learn regression forest fitted on (N, F) features.

    With ``oob`` it also holds ``oob_prediction_``: each sample predicted by the trees whose
    bootstrap left it out (0 for the rare sample every tree drew).
    """
    from sklearn.ensemble import RandomForestRegressor

    forest = RandomForestRegressor(
        n_estimators=n_trees, max_leaf_nodes=max_leaves, min_samples_leaf=min_samples_leaf,
        max_features=max_features, bootstrap=True, oob_score=oob, random_state=seed,
        n_jobs=n_jobs)
    return forest.fit(features.astype(np.float32), targets)


def fit_forest(features: np.ndarray, targets: FloatArray, cfg: TrainingConfig,
               seed: int) -> ForestArrays:
    """Fit the Hough forest on (N, F) features and (N, 3) targets; export it."""
    return export_forest(_regression_forest(features, targets, cfg.n_trees, cfg.max_leaves,
                                            cfg.min_samples_leaf, cfg.max_features, seed,
                                            cfg.n_jobs).estimators_)


def fit_verifiers(samples: list[PeakSamples], cfg: TrainingConfig,
                  seed: int) -> tuple[ForestArrays, ForestArrays]:
    """Fit the verifier and the context verifier on the vote peaks of the verifier views.

    The verifier is a regression forest on 0/1 labels: it predicts the leaf frequency of
    true tips, i.e. the tip probability, and exports to the same flat arrays as the Hough
    forest (K = 1). The context verifier is a gradient-boosted tree classifier exported to
    the same arrays; their mean leaf value is its logit (:func:`export_boosted`). The
    context features of the training peaks come from the first verifier's out-of-bag scores
    (scores of labelled peaks by trees that never saw them; peaks left out of its training
    are scored by all trees), so the context verifier learns from the scores the first one
    gives on new images, not from its fit to its own training set.

    Returns
    -------
    verifier, context : ForestArrays
    """
    features = np.concatenate([s.features for s in samples])
    labels = np.concatenate([s.labels for s in samples])
    keep = np.concatenate([s.keep for s in samples])
    first = _regression_forest(features[keep], labels[keep], cfg.verifier_trees,
                               cfg.verifier_max_leaves, cfg.verifier_min_samples_leaf,
                               cfg.verifier_max_features, seed, cfg.n_jobs, oob=True)
    verifier = export_forest(first.estimators_)
    score = predict(verifier.nodes(), features.astype(np.float32))[:, 0]
    score[keep] = first.oob_prediction_
    split = np.cumsum([s.uv_px.shape[0] for s in samples])[:-1]
    context = np.concatenate([context_features(s.uv_px, part) for s, part in
                              zip(samples, np.split(score, split), strict=True)])
    both = np.concatenate([features, context], axis=1)
    return verifier, _boosted_context(both[keep], labels[keep], cfg, seed)


def _boosted_context(features: np.ndarray, labels: FloatArray, cfg: TrainingConfig,
                     seed: int) -> ForestArrays:
    """Fit the context verifier on (N, F) features and (N,) 0/1 labels; export it."""
    from sklearn.ensemble import HistGradientBoostingClassifier

    boosted = HistGradientBoostingClassifier(
        learning_rate=cfg.context_learning_rate, max_iter=cfg.context_iterations,
        max_leaf_nodes=cfg.context_max_leaves, early_stopping=True, validation_fraction=0.1,
        n_iter_no_change=10, random_state=seed)
    boosted.fit(features.astype(np.float32), labels.astype(int))
    return export_boosted(boosted)


def export_boosted(boosted) -> ForestArrays:
    """A fitted binary scikit-learn ``HistGradientBoostingClassifier`` as
    :class:`ForestArrays` (K = 1) whose :func:`.forest.predict` value is its logit.

    ``predict`` averages the T trees, so leaf values are stored times T, and the baseline
    logit is added to every node of the first tree. Splits send ``x <= threshold`` left,
    as in scikit-learn; the features must hold no NaN (missing values are not exported).
    """
    trees = [predictors[0].nodes for predictors in boosted._predictors]
    roots, left, right, feature, threshold, value = [], [], [], [], [], []
    offset = 0
    for t, nodes in enumerate(trees):
        internal = nodes['is_leaf'] == 0
        roots.append(offset)
        left.append(np.where(internal, nodes['left'].astype(np.int64) + offset, -1))
        right.append(np.where(internal, nodes['right'].astype(np.int64) + offset, -1))
        feature.append(np.where(internal, nodes['feature_idx'], -1))
        threshold.append(nodes['num_threshold'])
        leaf = nodes['value'] * len(trees)
        value.append(leaf + len(trees) * float(boosted._baseline_prediction.ravel()[0])
                     if t == 0 else leaf)
        offset += nodes.size
    return _concatenated(roots, left, right, feature, threshold,
                         [v[:, None] for v in value])


def _concatenated(roots: list[int], left: list[np.ndarray], right: list[np.ndarray],
                  feature: list[np.ndarray], threshold: list[np.ndarray],
                  value: list[np.ndarray]) -> ForestArrays:
    """Per-tree node arrays (already offset to global node ids) as one :class:`ForestArrays`."""
    return ForestArrays(roots=np.asarray(roots, dtype=np.int32),
                        left=np.concatenate(left).astype(np.int32),
                        right=np.concatenate(right).astype(np.int32),
                        feature=np.concatenate(feature).astype(np.int32),
                        threshold=np.concatenate(threshold).astype(np.float64),
                        value=np.concatenate(value).astype(np.float64))


def _accept_all() -> ForestArrays:
    """A one-leaf verifier of probability 1: the detector of a model still in training."""
    return ForestArrays(roots=np.zeros(1, np.int32), left=np.full(1, -1, np.int32),
                        right=np.full(1, -1, np.int32), feature=np.full(1, -1, np.int32),
                        threshold=np.zeros(1), value=np.ones((1, 1)))


@dataclass(frozen=True, eq=False)
class PeakSamples:
    """The vote peaks of one verifier view.

    Attributes
    ----------
    uv_px : (N, 2) float64
        Peak positions.
    features : (N, verifier.N_FEATURES) float32
    labels : (N,) float64
        1 within ``verify_radius_px`` of a visible tip, else 0.
    keep : (N,) bool
        Labelled peaks: false for peaks near only invisible tips (the evaluation counts
        them neither way, so no verifier trains on them; they still give context).
    """

    uv_px: FloatArray
    features: np.ndarray
    labels: FloatArray
    keep: np.ndarray


def _verifier_samples(detector: FingertipDetector, views: Iterable[LabelledView],
                      radius_px: float) -> list[PeakSamples]:
    """The vote peaks of ``views`` with their features and labels, one entry per view."""
    samples = []
    for view in views:
        uv, features = detector.peaks(view.image)
        tips = np.nan_to_num(view.tips_uv, nan=-1e9)
        near = np.linalg.norm(uv[:, None] - tips[None], axis=2) <= radius_px   # (N, 5)
        positive = (near & view.tips_visible).any(axis=1)
        samples.append(PeakSamples(uv, features, positive.astype(np.float64),
                                   positive | ~near.any(axis=1)))
    return samples


def _hard_negatives(forest: ForestArrays, bank: np.ndarray, lut: UInt8Array, gate: int,
                    views: list[LabelledView], cfg: TrainingConfig
                    ) -> tuple[np.ndarray, FloatArray]:
    """Features (N, F) int16 and zero targets (N, 3) of the hardest negative candidates."""
    nodes = forest.nodes()
    blocks = []
    for view in views:
        channels = compute_channels(view.image, lut)
        ys, xs = candidates(gate_image(channels) >= gate, cfg.stride)
        d_vis, d_hid = (d[ys, xs] for d in _tip_distances(view.hand_mask.shape, view)[:2])
        keep = (d_vis > cfg.radius_px) & (d_hid > cfg.radius_px)
        feats = feature_matrix(channels, bank, ys[keep], xs[keep])
        weight = predict(nodes, feats)[:, 0]
        order = np.argsort(-weight, kind='stable')[:cfg.hard_negatives_per_view]
        blocks.append(feats[order[weight[order] >= cfg.hard_min_weight]])
    features = np.concatenate(blocks)
    return features, np.zeros((len(features), 3))


def _vote_norm(model: DetectorModel, views: list[LabelledView]) -> float:
    """Median smoothed vote peak within radius_px of each visible tip."""
    detector = FingertipDetector(model, DetectorConfig())
    sigma = DetectorConfig().smoothing_sigma_px
    peaks = []
    for view in views:
        smoothed = smooth_votes(detector.votes(view.image), sigma)
        vs, us = np.mgrid[0:smoothed.shape[0], 0:smoothed.shape[1]]
        for u, v in view.tips_uv[view.tips_visible]:
            near = np.hypot(us - u, vs - v) <= model.radius_px
            peaks.append(float(smoothed[near].max(initial=0.0)))
    return float(np.median(peaks)) if peaks and np.median(peaks) > 0 else 1.0


def train(seed: int, cfg: TrainingConfig = TrainingConfig(),
          model: HandModel | None = None) -> DetectorModel:
    """Render, sample, fit and calibrate a detector model (deterministic in ``seed``)."""
    views = list(labelled_views(cfg.n_views, seed, model=model))
    lut, gate = _skin_model(views, cfg.gate_quantile, cfg.radius_px)
    rng = np.random.default_rng([seed, 1])
    bank = random_bank(cfg.n_features, cfg.window_px, cfg.pair_fraction, rng)
    blocks, targets = [], []
    for view in views:
        channels = compute_channels(view.image, lut)
        ys, xs, t = _sample_view(view, channels, gate, cfg, rng)
        blocks.append(feature_matrix(channels, bank, ys, xs))
        targets.append(t)
    features, target = np.concatenate(blocks), np.concatenate(targets)
    logger.info('training on %d samples (%d positive) from %d views, gate %d',
                len(target), int(target[:, 0].sum()), len(views), gate)
    forest = fit_forest(features, target, cfg, seed)
    if cfg.hard_negatives_per_view > 0:
        hard, zeros = _hard_negatives(forest, bank, lut, gate, views, cfg)
        logger.info('refitting with %d hard negatives', len(hard))
        forest = fit_forest(np.concatenate([features, hard]), np.concatenate([target, zeros]),
                            cfg, seed)
    provisional = DetectorModel(bank=bank, forest=forest, verifier=_accept_all(),
                                context=_accept_all(), skin_lut=lut,
                                stride=cfg.stride, gate=gate, radius_px=cfg.radius_px,
                                vote_norm=1.0, peak_floor=cfg.peak_floor,
                                max_peaks=cfg.max_peaks, seed=seed)
    norm = _vote_norm(provisional, views[:cfg.calibration_views])
    provisional = dataclasses.replace(provisional, vote_norm=norm)
    del views  # free the forest views before rendering the verifier views
    # Scene numbers from n_views on were never rendered for the forest (a scene has at
    # least one view), so the verifier learns from the forest's held-out behaviour.
    fresh = labelled_views(cfg.verifier_views, seed, model=model, first_scene=cfg.n_views)
    samples = _verifier_samples(FingertipDetector(provisional), fresh, cfg.verify_radius_px)
    logger.info('verifiers on %d peaks (%d true tips)', sum(int(s.keep.sum()) for s in samples),
                sum(int(s.labels.sum()) for s in samples))
    verifier, context = fit_verifiers(samples, cfg, seed)
    return dataclasses.replace(provisional, verifier=verifier, context=context)
