"""Leave-one-subject-out severity regression."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fma.severity import SeverityResult, regress_severity
from fusion.errors import BadInputError

pytestmark = pytest.mark.usefixtures("small_forests")


def dataset(seed, *, n_subjects=12, per_subject=4, informative=True):
    """Subjects with scores 20-66; one feature carries the score (plus noise) when informative."""
    rng = np.random.default_rng(seed)
    scores = rng.uniform(20, 66, n_subjects).round()
    subjects = np.repeat([f"s{i:02d}" for i in range(n_subjects)], per_subject)
    y = np.repeat(scores, per_subject)
    X = rng.normal(size=(y.size, 5))
    if informative:
        X[:, 0] = y / 10.0 + rng.normal(0.0, 0.1, y.size)
    return X, y, subjects


def test_smoke_shapes_and_order():
    X, y, g = dataset(0)
    r = regress_severity(X, y, g, rng=np.random.default_rng(0))
    assert isinstance(r, SeverityResult)
    assert r.subjects.tolist() == sorted(set(g.tolist())) and r.truth.shape == r.predicted.shape == (12,)
    assert r.truth.tolist() == [y[g == s][0] for s in r.subjects]


def test_recovers_an_informative_feature_and_beats_the_baseline():
    X, y, g = dataset(1)
    r = regress_severity(X, y, g, rng=np.random.default_rng(0))
    assert r.mae < 0.5 * r.baseline_mae and r.correlation > 0.9
    # oracle of the baseline: leave-one-out mean of the other subjects' scores
    truth = r.truth
    loo = np.array([(truth.sum() - t) / (truth.size - 1) for t in truth])
    assert r.baseline_mae == pytest.approx(np.mean(np.abs(loo - truth)))


@settings(max_examples=5)
@given(seed=st.integers(0, 2**32 - 1))
def test_noise_features_do_not_beat_the_baseline_by_much(seed):
    X, y, g = dataset(seed, informative=False)
    r = regress_severity(X, y, g, rng=np.random.default_rng(0))
    assert r.mae > 0.6 * r.baseline_mae


def test_nan_features_are_imputed_and_results_reproducible():
    X, y, g = dataset(2)
    X[::3, 1] = np.nan
    a = regress_severity(X, y, g, rng=np.random.default_rng(4))
    b = regress_severity(X, y, g, rng=np.random.default_rng(4))
    assert np.array_equal(a.predicted, b.predicted) and np.isfinite(a.predicted).all()


def test_bad_input():
    X, y, g = dataset(3)
    rng = np.random.default_rng(0)
    with pytest.raises(BadInputError, match="three subjects"):
        regress_severity(X[:8], y[:8], g[:8], rng=rng)
    with pytest.raises(BadInputError, match=r"\(N, F\)"):
        regress_severity(X[:, 0], y, g, rng=rng)
    bad = y.copy()
    bad[1] += 1
    with pytest.raises(BadInputError, match="one score"):
        regress_severity(X, bad, g, rng=rng)
    with pytest.raises(BadInputError, match="finite"):
        regress_severity(X, np.where(np.arange(y.size) == 0, np.nan, y), g, rng=rng)
