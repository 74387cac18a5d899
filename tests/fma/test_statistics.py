"""Seed intervals and balanced class metrics."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy import stats
from sklearn.metrics import balanced_accuracy_score, f1_score, recall_score

from fma.classify import class_metrics
from fma.statistics import Interval, mean_interval
from fusion.errors import BadInputError


@given(values=st.lists(st.floats(-100, 100), min_size=2, max_size=12))
def test_mean_interval_matches_scipy(values):
    iv = mean_interval(values)
    x = np.asarray(values)
    assert iv.n == x.size and iv.mean == pytest.approx(x.mean(), abs=1e-9)
    if x.std() > 1e-9:
        low, high = stats.t.interval(0.95, x.size - 1, loc=x.mean(), scale=stats.sem(x))
        assert (iv.low, iv.high) == pytest.approx((low, high), abs=1e-6)
    assert iv.low <= iv.mean <= iv.high


def test_mean_interval_edge_cases():
    assert mean_interval([3.0]) == Interval(3.0, 3.0, 3.0, 1, 0.95)
    empty = mean_interval([np.nan])
    assert empty.n == 0 and np.isnan(empty.mean) and str(empty) == "n/a"
    assert mean_interval([1.0, np.nan, 3.0]).n == 2
    narrow, wide = mean_interval([1.0, 2.0, 3.0], 0.5), mean_interval([1.0, 2.0, 3.0], 0.99)
    assert wide.high - wide.low > narrow.high - narrow.low
    with pytest.raises(BadInputError, match="confidence"):
        mean_interval([1.0, 2.0], confidence=1.0)


@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 40), k=st.integers(2, 4))
def test_class_metrics_match_sklearn(seed, n, k):
    rng = np.random.default_rng(seed)
    t, p = rng.integers(0, k, n), rng.integers(0, k, n)
    m = class_metrics(t, p)
    present = np.unique(t)
    assert m.confusion.sum() == n and m.confusion.shape == (m.classes.size, m.classes.size)
    assert m.balanced_accuracy == pytest.approx(balanced_accuracy_score(t, p))
    assert m.macro_f1 == pytest.approx(f1_score(t, p, labels=present, average="macro", zero_division=0))
    rec = recall_score(t, p, labels=present, average=None, zero_division=0)
    assert m.recall[np.isin(m.classes, present)] == pytest.approx(rec)


def test_class_metrics_fixed_classes_and_bad_input():
    m = class_metrics(np.array([1, 1, 2]), np.array([1, 2, 2]), classes=np.array([0, 1, 2]))
    assert m.classes.tolist() == [0, 1, 2] and np.isnan(m.recall[0]) and m.recall[1:].tolist() == [0.5, 1.0]
    assert m.macro_f1 == pytest.approx(np.mean([2 / 3, 2 / 3]))
    with pytest.raises(BadInputError, match="equal-length"):
        class_metrics(np.array([1, 2]), np.array([1]))
    with pytest.raises(BadInputError, match="equal-length"):
        class_metrics(np.array([]), np.array([]))
