"""The leg classifier: tree ensembles evaluated from their bundled arrays (no sklearn, no pickle).

``python -m cobotsafety.tools.train_legs`` trains a scikit-learn ``GradientBoostingClassifier``
on cluster features (``leg_features``) and exports its trees as plain arrays to
``assets/legs/leg_forest.npz``; a ``RandomForestClassifier`` packs the same way. All trees are
packed into one node table:

* ``feature`` (N,) int64: the feature a node splits on, -1 at a leaf;
* ``threshold`` (N,) float64: go left when ``float32(x[feature]) <= threshold`` (scikit-learn
  compares the features cast to float32);
* ``left``, ``right`` (N,) int64: global indices of the children;
* ``leaf_value`` (N,) float64: what a leaf adds (used at leaves): a random forest's share of leg
  samples at the leaf, or a boosted tree's value times the learning rate;
* ``roots`` (T,) int64: the root node of each tree;
* ``link``: how the leaves of a sample make its probability: ``"mean"`` (random forest: the
  mean of its leaves' values) or ``"logistic"`` (gradient boosting: the logistic function of
  ``base_score`` plus the sum of its leaves' values);
* ``base_score``: the boosted ensemble's initial log-odds (0 for a forest);
* ``feature_names``: the ``FEATURE_NAMES`` the forest was trained on (checked at load);
* ``threshold_probability``, ``threshold_probability_no_background``: the decision thresholds
  chosen by cross-validation for scans with a per-beam background (the background already
  removed the static leg-like clutter, so more of the remaining clusters are legs) and without.

The probability of a cluster is, by ``link``, exactly what scikit-learn's ``predict_proba``
returns. ``predict_reference`` is the readable version, ``predict`` the
compiled one; tests hold both equal to scikit-learn's ``predict_proba``.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from importlib.resources import files
from pathlib import Path

import numba
import numpy as np

from cobotsafety.sensors.leg_features import FEATURE_NAMES

MODEL_FILE = "leg_forest.npz"
LINKS = ("mean", "logistic")


@dataclass(frozen=True)
class LegForest:
    """A packed tree ensemble (arrays described in the module docstring)."""

    feature: np.ndarray
    threshold: np.ndarray
    left: np.ndarray
    right: np.ndarray
    leaf_value: np.ndarray
    roots: np.ndarray
    threshold_probability: float
    threshold_probability_no_background: float
    link: str = "mean"
    base_score: float = 0.0

    @classmethod
    def load(cls, path: Path) -> "LegForest":
        """Read a forest written by ``save``; plain arrays only (``allow_pickle=False``)."""
        with np.load(path, allow_pickle=False) as arrays:
            names = tuple(str(n) for n in arrays["feature_names"])
            if names != FEATURE_NAMES:
                raise ValueError(f"{path}: trained on features {names}, this code computes {FEATURE_NAMES}")
            forest = cls(arrays["feature"].astype(np.int64), arrays["threshold"].astype(np.float64),
                         arrays["left"].astype(np.int64), arrays["right"].astype(np.int64),
                         arrays["leaf_value"].astype(np.float64), arrays["roots"].astype(np.int64),
                         float(arrays["threshold_probability"]),
                         float(arrays["threshold_probability_no_background"]),
                         str(arrays["link"]), float(arrays["base_score"]))
        if forest.link not in LINKS:
            raise ValueError(f"{path}: link must be one of {LINKS}, got {forest.link!r}")
        n = forest.feature.size
        if not all(a.shape == (n,) for a in (forest.threshold, forest.left, forest.right, forest.leaf_value)):
            raise ValueError(f"{path}: node arrays of different lengths")
        inner = forest.feature >= 0
        if (np.any(forest.feature >= len(FEATURE_NAMES)) or np.any(forest.left[inner] <= np.flatnonzero(inner))
                or np.any(forest.right[inner] <= np.flatnonzero(inner)) or np.any(forest.left[inner] >= n)
                or np.any(forest.right[inner] >= n) or np.any(forest.roots >= n) or forest.roots.size == 0):
            raise ValueError(f"{path}: malformed tree arrays")
        return forest

    def save(self, path: Path) -> None:
        np.savez_compressed(path, feature=self.feature, threshold=self.threshold, left=self.left,
                            right=self.right, leaf_value=self.leaf_value, roots=self.roots,
                            link=np.array(self.link), base_score=np.float64(self.base_score),
                            feature_names=np.array(FEATURE_NAMES),
                            threshold_probability=np.float64(self.threshold_probability),
                            threshold_probability_no_background=np.float64(self.threshold_probability_no_background))

    @classmethod
    def from_sklearn(cls, forest, threshold_probability: float,
                     threshold_probability_no_background: float | None = None) -> "LegForest":
        """Pack a fitted ``RandomForestClassifier`` or ``GradientBoostingClassifier`` (log-loss)
        of classes 0 = other, 1 = leg."""
        from sklearn.ensemble import GradientBoostingClassifier

        if list(forest.classes_) != [0, 1]:
            raise ValueError(f"expected classes [0, 1], got {forest.classes_}")
        boosted = isinstance(forest, GradientBoostingClassifier)
        estimators = forest.estimators_[:, 0] if boosted else forest.estimators_
        feature, threshold, left, right, leaf_value, roots = [], [], [], [], [], []
        offset = 0
        for tree in (estimator.tree_ for estimator in estimators):
            leaf = tree.children_left < 0
            roots.append(offset)
            feature.append(np.where(leaf, -1, tree.feature))
            threshold.append(tree.threshold)
            left.append(np.where(leaf, -1, tree.children_left + offset))
            right.append(np.where(leaf, -1, tree.children_right + offset))
            if boosted:
                leaf_value.append(forest.learning_rate * tree.value[:, 0, 0])
            else:
                value = tree.value[:, 0, :]
                total = value.sum(axis=1)
                leaf_value.append(value[:, 1] / np.where(total == 0.0, 1.0, total))
            offset += tree.node_count
        base_score = 0.0
        if boosted:
            prior = float(forest.init_.predict_proba(np.zeros((1, forest.n_features_in_)))[0, 1])
            base_score = float(np.log(prior / (1.0 - prior)))
        cat = np.concatenate
        return cls(cat(feature).astype(np.int64), cat(threshold).astype(np.float64), cat(left).astype(np.int64),
                   cat(right).astype(np.int64), cat(leaf_value), np.array(roots, dtype=np.int64),
                   float(threshold_probability),
                   float(threshold_probability if threshold_probability_no_background is None
                         else threshold_probability_no_background),
                   "logistic" if boosted else "mean", base_score)

    def predict_reference(self, features: np.ndarray) -> np.ndarray:
        """Shape (c,): P(leg) of each row of ``features`` (c, N_FEATURES) (readable version)."""
        x = np.asarray(features, dtype=np.float32).astype(np.float64)
        total = np.zeros(x.shape[0])
        for root in self.roots.tolist():
            node = np.full(x.shape[0], root)
            while True:
                inner = self.feature[node] >= 0
                if not inner.any():
                    break
                rows = np.flatnonzero(inner)
                at = node[rows]
                go_left = x[rows, self.feature[at]] <= self.threshold[at]
                node[rows] = np.where(go_left, self.left[at], self.right[at])
            total += self.leaf_value[node]
        if self.link == "logistic":
            return 1.0 / (1.0 + np.exp(-(self.base_score + total)))
        return total / self.roots.size

    def predict(self, features: np.ndarray) -> np.ndarray:
        """Shape (c,): P(leg) of each row of ``features`` (compiled; equals the reference)."""
        x = np.ascontiguousarray(features, dtype=np.float32)  # compared as float64, as sklearn does
        return _predict_kernel(x, self.feature, self.threshold, self.left, self.right,
                               self.leaf_value, self.roots, self.link == "logistic", self.base_score)


@numba.njit(cache=True)
def _predict_kernel(x, feature, threshold, left, right, leaf_value, roots, logistic, base_score):
    out = np.zeros(x.shape[0])
    for i in range(x.shape[0]):
        total = 0.0
        for root in roots:
            node = root
            while feature[node] >= 0:
                node = left[node] if x[i, feature[node]] <= threshold[node] else right[node]
            total += leaf_value[node]
        out[i] = 1.0 / (1.0 + np.exp(-(base_score + total))) if logistic else total / roots.size
    return out


def bundled_model_path() -> Path:
    return Path(str(files("cobotsafety.assets") / "legs" / MODEL_FILE))


@lru_cache(maxsize=1)
def bundled_forest() -> LegForest:
    """The ensemble shipped in ``assets/legs`` (loaded once)."""
    return LegForest.load(bundled_model_path())
