r"""A trained Hough forest as plain arrays, and its numba traversal and voting kernels.

All T trees are concatenated into flat node arrays; tree t starts at node ``roots[t]`` and a
node is a leaf when ``left == -1``. An internal node sends a sample with feature value
:math:`f` left iff :math:`f \le \text{threshold}` (scikit-learn's rule, so the exported
trees predict exactly what scikit-learn predicts).

Each leaf holds the regression value :math:`(\bar y, \overline{y\,d_x}/R, \overline{y\,d_y}/R)`
that training fitted (``y`` = 1 for a candidate within ``R`` px of a visible tip, ``d`` the
offset from the candidate to that tip). At load time it becomes the vote
:math:`w = \bar y` (leaf tip probability) and the mean offset of the leaf's positives
:math:`o = R\, \overline{y d} / \bar y`.

Why numba: a scikit-learn ``predict`` call costs ~1 ms of Python/joblib overhead per forest
before any work and needs the (N, F) feature matrix materialised; the fused kernel here
evaluates only the ~depth features each tree asks for, straight from the channel images,
and accumulates the votes in the same pass.
``cache=True`` stores the compiled code on disk so only the first process pays the compile.
"""
from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from hand_tracker_ros._typing import Float32Array, FloatArray, Int32Array, IntArray, UInt8Array
from hand_tracker_ros.checks import check_shape


@dataclass(frozen=True, eq=False)
class ForestArrays:
    """The trees of one forest.

    Attributes
    ----------
    roots : (T,) int32
        First node of each tree.
    left, right : (M,) int32
        Child node indices (global), -1 at leaves.
    feature : (M,) int32
        Bank feature tested at the node (-1 at leaves).
    threshold : (M,) float64
        Split threshold.
    value : (M, K) float64
        Regression value of each node (meaningful at leaves): K = 3 for the Hough forest
        (tip probability and scaled offset), K = 1 for the verifier (tip probability).
    """

    roots: Int32Array
    left: Int32Array
    right: Int32Array
    feature: Int32Array
    threshold: FloatArray
    value: FloatArray

    def __post_init__(self) -> None:
        n = self.left.shape[0]
        for name in ('right', 'feature', 'threshold'):
            check_shape(name, getattr(self, name), (n,))
        check_shape('value', self.value, (n, None))
        check_shape('roots', self.roots, (None,))

    def nodes(self) -> tuple:
        """``(roots, left, right, feature, threshold, value)``: the ``forest_nodes`` of
        :func:`predict`."""
        return self.roots, self.left, self.right, self.feature, self.threshold, self.value

    def votes(self, radius_px: float) -> tuple[Float32Array, Float32Array]:
        """Per-node vote weight (M,) float32 and offset (M, 2) float32 (dx, dy px)."""
        weight = np.clip(self.value[:, 0], 0.0, 1.0)
        offset = radius_px * self.value[:, 1:] / np.maximum(self.value[:, :1], 1e-6)
        return weight.astype(np.float32), offset.astype(np.float32)


@numba.njit(cache=True, nogil=True)
def _leaf(left: Int32Array, right: Int32Array, feature: Int32Array, threshold: FloatArray,
          root: int, x: np.ndarray) -> int:
    node = root
    while left[node] != -1:
        node = left[node] if x[feature[node]] <= threshold[node] else right[node]
    return node


@numba.njit(cache=True, nogil=True)
def predict(forest_nodes: tuple, features: np.ndarray) -> FloatArray:
    """Mean leaf value over the trees for precomputed features (the scikit-learn oracle).

    Parameters
    ----------
    forest_nodes : (roots, left, right, feature, threshold, value)
        The arrays of a :class:`ForestArrays`.
    features : (N, F) int16 or float32

    Returns
    -------
    value : (N, K) float64
    """
    roots, left, right, feature, threshold, value = forest_nodes
    out = np.zeros((features.shape[0], value.shape[1]))
    for i in range(features.shape[0]):
        x = features[i].astype(np.float32)
        for t in range(roots.shape[0]):
            node = _leaf(left, right, feature, threshold, roots[t], x)
            out[i] += value[node]
    return out / roots.shape[0]


def pack_nodes(forest: ForestArrays, bank: Int32Array) -> Int32Array:
    """The forest and its pixel tests packed per node for the voting kernel.

    One 32-byte row per node ``(left, right, floor(threshold), c + 8 * pair, dy1, dx1,
    dy2, dx2)`` puts everything a node visit reads in one cache line, instead of chasing
    ``feature -> bank -> threshold`` in separate arrays. Features are integers, so
    ``f <= threshold`` iff ``f <= floor(threshold)``.

    Returns
    -------
    packed : (M, 8) int32
    """
    tests = bank[np.maximum(forest.feature, 0)]
    packed = np.zeros((forest.left.size, 8), dtype=np.int32)
    packed[:, 0], packed[:, 1] = forest.left, forest.right
    packed[:, 2] = np.floor(np.clip(forest.threshold, -2.0**30, 2.0**30))
    packed[:, 3] = tests[:, 0] + 8 * tests[:, 5]
    packed[:, 4:8] = tests[:, 1:5]
    return packed


@numba.njit(cache=True, nogil=True)
def vote(channels: UInt8Array, ys: IntArray, xs: IntArray, roots: Int32Array,
         packed: Int32Array, weight: Float32Array, offset: Float32Array,
         min_weight: float, accumulator: Float32Array) -> None:
    """Let every candidate vote with every tree into ``accumulator`` (H, W) float32, in place.

    A candidate at (y, x) reaching a leaf with weight ``w >= min_weight`` adds ``w / T`` at
    the pixel nearest to ``(x + o_x, y + o_y)`` (votes off the image are dropped). The pixel
    test is the one of :func:`.channels.feature_value`, read from ``packed``
    (:func:`pack_nodes`).
    """
    height, width = accumulator.shape
    scale = np.float32(1.0 / roots.shape[0])
    for i in range(ys.shape[0]):
        y, x = ys[i], xs[i]
        for t in range(roots.shape[0]):
            node = roots[t]
            while packed[node, 0] != -1:
                kind = packed[node, 3]
                c = kind & 7
                f = np.int32(channels[c, min(max(y + packed[node, 4], 0), height - 1),
                                      min(max(x + packed[node, 5], 0), width - 1)])
                if kind >= 8:
                    f -= np.int32(channels[c, min(max(y + packed[node, 6], 0), height - 1),
                                           min(max(x + packed[node, 7], 0), width - 1)])
                node = packed[node, 0] if f <= packed[node, 2] else packed[node, 1]
            w = weight[node]
            if w < min_weight:
                continue
            u = int(np.rint(x + offset[node, 0]))
            v = int(np.rint(y + offset[node, 1]))
            if 0 <= u < width and 0 <= v < height:
                accumulator[v, u] += w * scale
