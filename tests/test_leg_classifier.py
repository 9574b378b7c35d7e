"""The packed tree ensembles (random forest, gradient boosting): load without sklearn or pickle,
and predict exactly what scikit-learn's ``predict_proba`` does (the oracle) on real cluster
features."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from sklearn.ensemble import GradientBoostingClassifier, RandomForestClassifier

from cobotsafety.sensors.leg_classifier import LegForest, bundled_forest, bundled_model_path
from cobotsafety.sensors.leg_features import FEATURE_NAMES
from cobotsafety.tools.train_legs import labelled_examples, load_bags


@pytest.fixture(scope="module")
def real_features(shared_data):
    bags = load_bags(shared_data / "leg_tracker")
    xs, ys = [], []
    for name in ("positive_2_extracted.bag", "negative_2.bag/left_scan"):
        for scan, labels in bags[name][::2]:
            x, y = labelled_examples(scan, labels)
            xs.append(x)
            ys.append(y)
    return np.concatenate(xs), np.concatenate(ys)


@pytest.mark.parametrize("make", [
    lambda: RandomForestClassifier(n_estimators=15, min_samples_leaf=2, random_state=3, n_jobs=1),
    lambda: GradientBoostingClassifier(n_estimators=40, max_depth=3, learning_rate=0.2, subsample=0.8, random_state=3),
], ids=["random_forest", "gradient_boosting"])
def test_packed_ensemble_equals_sklearn_predict_proba(real_features, tmp_path, make):
    x, y = real_features
    assert 40 < y.sum() < y.size  # both classes present
    weight = np.where(y == 1, 5.0, 1.0)  # a prior that is not the class shares (the boosted base score)
    forest = make().fit(x, y, sample_weight=weight)
    packed = LegForest.from_sklearn(forest, 0.5)
    assert packed.link == ("logistic" if isinstance(forest, GradientBoostingClassifier) else "mean")
    packed.save(tmp_path / "forest.npz")
    loaded = LegForest.load(tmp_path / "forest.npz")
    oracle = forest.predict_proba(x)[:, 1]
    assert oracle.min() < 0.5 < oracle.max()
    np.testing.assert_allclose(loaded.predict(x), oracle, rtol=0, atol=1e-12)
    np.testing.assert_allclose(loaded.predict_reference(x), oracle, rtol=0, atol=1e-12)
    # Features near a split threshold: scikit-learn compares in float32, so must we.
    jitter = x * (1 + 1e-9 * np.random.default_rng(0).standard_normal(x.shape))
    np.testing.assert_allclose(loaded.predict(jitter), forest.predict_proba(jitter)[:, 1], rtol=0, atol=1e-12)


def test_bundled_model_loads_without_sklearn_or_pickle():
    code = (
        "import sys; sys.modules['sklearn'] = None\n"
        "import numpy as np\n"
        "load = np.load\n"
        "def no_pickle(*args, **kwargs):\n"
        "    assert kwargs.get('allow_pickle') is False, 'np.load may unpickle'\n"
        "    return load(*args, **kwargs)\n"
        "np.load = no_pickle\n"
        "from cobotsafety.sensors.leg_classifier import bundled_forest\n"
        "from cobotsafety import LaserScan, detect_legs\n"
        "forest = bundled_forest()\n"
        "a = -np.pi / 2 + np.pi / 360 * np.arange(361); disc = np.cos(a) ** 2 - (1.0 - 0.06 ** 2)\n"
        "r = np.where(disc >= 0, np.cos(a) - np.sqrt(np.abs(disc)), np.inf)  # a leg at 1 m\n"
        "legs = detect_legs(LaserScan(-np.pi / 2, np.pi / 360, 0.05, 10.0, r), 3.0)\n"
        "print(forest.roots.size, legs.shape)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    trees, shape = out.stdout.split(" ", 1)
    assert int(trees) > 10
    assert shape.strip() == "(1, 2)"
    with np.load(bundled_model_path(), allow_pickle=False) as arrays:
        assert tuple(str(n) for n in arrays["feature_names"]) == FEATURE_NAMES
        assert all(arrays[k].dtype != object for k in arrays.files)


def test_bundled_model_is_sane():
    forest = bundled_forest()
    assert 0.0 < forest.threshold_probability < 1.0
    assert 0.0 < forest.threshold_probability_no_background < 1.0
    assert forest.link in ("mean", "logistic")
    assert np.all(np.isfinite(forest.leaf_value)) and np.isfinite(forest.base_score)
    if forest.link == "mean":
        assert np.all((forest.leaf_value >= 0) & (forest.leaf_value <= 1))


def test_malformed_model_files_are_refused(tmp_path):
    forest = bundled_forest()
    broken = LegForest(forest.feature, forest.threshold, forest.left.copy(), forest.right, forest.leaf_value,
                       forest.roots, 0.5, 0.5, forest.link, forest.base_score)
    broken.left[int(np.flatnonzero(forest.feature >= 0)[0])] = forest.feature.size + 5
    broken.save(tmp_path / "broken.npz")
    with pytest.raises(ValueError, match="malformed"):
        LegForest.load(tmp_path / "broken.npz")
    np.savez(tmp_path / "other.npz", feature=forest.feature, threshold=forest.threshold, left=forest.left,
             right=forest.right, leaf_value=forest.leaf_value, roots=forest.roots, link=np.array(forest.link),
             base_score=forest.base_score,
             feature_names=np.array(["a", "b"]), threshold_probability=0.5,
             threshold_probability_no_background=0.5)
    with pytest.raises(ValueError, match="trained on features"):
        LegForest.load(tmp_path / "other.npz")


def test_training_is_deterministic(real_features):
    """The training command's recipe (fixed seed) gives the same forest twice."""
    from cobotsafety.tools.train_legs import fit

    x, y = real_features
    a = LegForest.from_sklearn(fit(x, y), 0.5)
    b = LegForest.from_sklearn(fit(x, y), 0.5)
    assert a.base_score == b.base_score
    for name in ("feature", "threshold", "left", "right", "leaf_value", "roots"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
