import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fma.features import (
    FEATURE_NAMES,
    STATISTICS,
    DataVariant,
    Derivative,
    FeatureTable,
    apply_variant,
    asymmetry,
    feature_names,
    repetition_average,
    repetition_features,
    segments_features,
)
from fma.measurements import MEASUREMENT_NAMES
from fma.segmentation import RepetitionSegment
from fusion.errors import BadInputError

DT = 0.05


def seg(times, start, end):
    return RepetitionSegment(start, start, end, float(times[start]), float(times[end]))


def by_name(f, measurement):
    return {s: f[FEATURE_NAMES.index(f"{measurement} {s}")] for s in STATISTICS}


def test_names():
    assert len(FEATURE_NAMES) == 1 + 13 * 13 == len(set(FEATURE_NAMES))
    assert FEATURE_NAMES[0] == "Time length"
    assert "Distance(Head-Elbow) speed average" in FEATURE_NAMES
    assert feature_names(("a",)) == ("Time length",) + tuple(f"a {s}" for s in STATISTICS)


@given(a=st.floats(-5, 5), b=st.floats(-5, 5), start=st.integers(0, 20), length=st.integers(3, 60))
def test_linear_ramp(a, b, start, length):
    t = np.arange(100) * DT
    m = np.repeat((a + b * t)[:, None], 13, axis=1)
    s = seg(t, start, start + length - 1)
    f = repetition_features(t, m, s)
    ts = t[start:start + length]
    assert f.shape == (170,)
    assert f[0] == pytest.approx(ts[-1] - ts[0])
    got = by_name(f, MEASUREMENT_NAMES[4])
    want = {"min": a + b * ts.min() if b >= 0 else a + b * ts.max(), "max": a + b * (ts.max() if b >= 0 else ts.min()),
            "mean": a + b * ts.mean(), "variance": b**2 * ts.var(), "start-stop difference": b * (ts[-1] - ts[0]),
            "speed average": b, "speed min": b, "speed max": b, "speed variance": 0.0,
            "acceleration average": 0.0, "acceleration min": 0.0, "acceleration max": 0.0, "acceleration variance": 0.0}
    for k, v in want.items():
        assert got[k] == pytest.approx(v, abs=1e-7), k


def test_parabola_hand_computed():
    t = np.arange(0, 41) * DT  # 0 .. 2 s
    c = 0.5
    m = np.zeros((t.size, 13))
    m[:, 0] = c * (t - 1.0) ** 2  # vertex at t = 1 s
    f = repetition_features(t, m, seg(t, 0, 40))
    got = by_name(f, MEASUREMENT_NAMES[0])
    speed = 2 * c * (t - 1.0)
    assert f[0] == pytest.approx(2.0)
    assert got["min"] == pytest.approx(0.0, abs=1e-12)
    assert got["max"] == pytest.approx(0.5)
    assert got["mean"] == pytest.approx(np.mean(c * (t - 1) ** 2))
    assert got["start-stop difference"] == pytest.approx(0.0, abs=1e-12)
    assert got["speed average"] == pytest.approx(0.0, abs=1e-12)
    assert got["speed min"] == pytest.approx(-1.0) and got["speed max"] == pytest.approx(1.0)
    assert got["speed variance"] == pytest.approx(speed.var())
    assert got["acceleration average"] == pytest.approx(1.0)
    assert got["acceleration variance"] == pytest.approx(0.0, abs=1e-12)
    mag = by_name(repetition_features(t, m, seg(t, 0, 40), derivative=Derivative.MAGNITUDE), MEASUREMENT_NAMES[0])
    assert mag["speed average"] == pytest.approx(np.abs(speed).mean())
    assert mag["speed min"] == pytest.approx(0.0, abs=1e-12)
    zero = by_name(f, MEASUREMENT_NAMES[1])
    assert all(v == 0 for v in zero.values())


def test_nan_samples_are_ignored_and_all_nan_gives_nan():
    t = np.arange(30) * DT
    m = np.repeat((2 * t)[:, None], 13, axis=1)
    m[10, 0] = np.nan
    m[:, 1] = np.nan
    m[0, 2] = np.nan
    f = repetition_features(t, m, seg(t, 0, 29))
    g0, g1, g2 = (by_name(f, MEASUREMENT_NAMES[k]) for k in range(3))
    assert g0["mean"] == pytest.approx(np.delete(2 * t, 10).mean())
    assert g0["speed average"] == pytest.approx(2.0)
    assert all(np.isnan(v) for v in g1.values())
    assert g2["start-stop difference"] == pytest.approx(2 * (t[29] - t[1]))


def test_segments_features_and_bad_input():
    t = np.arange(50) * DT
    m = np.random.default_rng(0).normal(size=(50, 13))
    segs = [seg(t, 0, 10), seg(t, 20, 45)]
    F = segments_features(t, m, segs)
    assert F.shape == (2, 170)
    np.testing.assert_array_equal(F[1], repetition_features(t, m, segs[1]))
    assert segments_features(t, m, []).shape == (0, 170)
    with pytest.raises(BadInputError):
        repetition_features(t, m, seg(t, 0, 1))
    with pytest.raises(BadInputError):
        repetition_features(t[:20], m, seg(t, 0, 10))
    with pytest.raises(BadInputError):
        repetition_features(t, m, RepetitionSegment(40, 40, 60, 2.0, 3.0))


def table(X, subjects, sides, labels):
    return FeatureTable(np.array(X, dtype=float), ("f0", "f1", "f2"), subjects, sides, labels)


def test_repetition_average_and_asymmetry_hand_computed():
    t = table(
        [[1, 0, 2], [3, 0, 4], [1, 0, -4], [5, 0, np.nan], [2, 1, 1], [2, 3, 1]],
        ["s1", "s1", "s1", "s2", "s2", "s2"], ["left", "left", "right", "right", "left", "left"], [1, 1, 1, 0, 0, 0],
    )
    avg = repetition_average(t)
    assert avg.n_samples == 4
    rows = {(s, d): x for s, d, x in zip(avg.subjects, avg.sides, avg.X)}
    np.testing.assert_allclose(rows["s1", "left"], [2, 0, 3])
    np.testing.assert_allclose(rows["s2", "right"], [5, 0, np.nan])
    np.testing.assert_allclose(rows["s2", "left"], [2, 2, 1])
    asym = asymmetry(t)
    assert list(asym.subjects) == ["s1", "s2"] and list(asym.labels) == [1, 0] and set(asym.sides) == {"both"}
    np.testing.assert_allclose(asym.X[0], [abs(1 - 2) / 3, 0.0, abs(-4 - 3) / 1])  # 0/0 := 0
    np.testing.assert_allclose(asym.X[1], [3 / 7, 1.0, np.nan])
    assert apply_variant(t, DataVariant.RAW) is t
    assert apply_variant(t, DataVariant.ASYMMETRY).n_samples == 2


def test_variant_errors():
    with pytest.raises(BadInputError, match="both sides"):
        asymmetry(table([[1, 1, 1], [1, 1, 1]], ["a", "b"], ["left", "right"], [0, 1]))
    with pytest.raises(BadInputError, match="labels differ"):
        repetition_average(table([[1, 1, 1], [1, 1, 1]], ["a", "a"], ["left", "left"], [0, 1]))
    with pytest.raises(BadInputError):
        table([[1, 1, 1]], ["a"], ["up"], [0])
    with pytest.raises(BadInputError):
        table([[1, 1]], ["a"], ["left"], [0])
    with pytest.raises(BadInputError):
        table([[1, 1, 1]], ["a"], ["left"], [0.5])
