import numpy as np
import pytest
from joblib import parallel_config
from scipy import stats

from fma.classify import (
    ClassifierKind,
    RankingMethod,
    evaluate_classifiers,
    loso_folds,
    make_classifier,
    out_of_fold_predictions,
    rank_features,
)
from fma.segmentation import RepetitionSegment
from fma.statistics import (
    COMPENSATION_NAMES,
    compensation_measures,
    t_tests_markdown,
    welch_t_tests,
)
from fusion.errors import BadInputError
from fusion.topology import KINECT_V2, Landmark


def cohort(seed, *, n_subjects=16, per_subject=5, n_classes=2, informative=True):
    """Samples grouped by subject; the label is per subject; 2 informative + 6 noise features."""
    rng = np.random.default_rng(seed)
    subject_labels = np.arange(n_subjects) % n_classes
    groups = np.repeat([f"s{i:02d}" for i in range(n_subjects)], per_subject)
    y = np.repeat(subject_labels, per_subject)
    X = rng.normal(size=(y.size, 8))
    if informative:
        X[:, :2] += 4.0 * y[:, None]
    return X, y, groups


def test_folds_never_share_a_subject():
    X, y, g = cohort(0)
    g = np.random.default_rng(1).permutation(g)  # subjects interleaved, not contiguous
    folds = loso_folds(g)
    assert len(folds) == 16
    tested = np.concatenate([f.test_index for f in folds])
    assert np.array_equal(np.sort(tested), np.arange(g.size))
    for f in folds:
        assert set(g[f.test_index]) == {f.test_group}
        assert f.test_group not in set(g[f.train_index])
        assert f.train_index.size + f.test_index.size == g.size
    res = evaluate_classifiers(X, y, g, rng=np.random.default_rng(2), kinds=(ClassifierKind.DECISION_TREE,))
    for f in res[ClassifierKind.DECISION_TREE].folds:
        assert not set(g[f.train_index]) & set(g[f.test_index])


@pytest.mark.usefixtures("small_forests")
def test_separable_cohort_is_classified_well():
    X, y, g = cohort(3)
    X[0, 3] = np.nan  # imputed
    res = evaluate_classifiers(X, y, g, rng=np.random.default_rng(4))
    assert set(res) == set(ClassifierKind)
    for kind, r in res.items():
        assert r.kind is kind
        assert r.accuracy >= 0.9, kind
        assert r.confusion.shape == (2, 2) and r.confusion.sum() == y.size
        assert r.accuracy == pytest.approx(np.trace(r.confusion) / y.size)
        assert r.predictions.shape == y.shape


@pytest.mark.usefixtures("small_forests")
def test_shuffled_labels_are_near_chance():
    accs = []
    for seed in range(3):
        X, y, g = cohort(10 + seed, n_subjects=30, per_subject=4, informative=False)
        res = evaluate_classifiers(X, y, g, rng=np.random.default_rng(seed))
        accs += [r.accuracy for r in res.values()]
    assert 0.3 < np.mean(accs) < 0.7
    assert max(accs) < 0.8


@pytest.mark.usefixtures("small_forests")
def test_item_scores_multiclass():
    X, y, g = cohort(5, n_subjects=18, n_classes=3)
    res = evaluate_classifiers(X, y, g, rng=np.random.default_rng(6), kinds=(ClassifierKind.RANDOM_FOREST,))
    r = res[ClassifierKind.RANDOM_FOREST]
    assert r.confusion.shape == (3, 3) and list(r.classes) == [0, 1, 2]
    assert r.accuracy >= 0.9


@pytest.mark.usefixtures("small_forests")
def test_same_seed_same_results():
    X, y, g = cohort(7)
    a = evaluate_classifiers(X, y, g, rng=np.random.default_rng(8))
    b = evaluate_classifiers(X, y, g, rng=np.random.default_rng(8))
    for k in ClassifierKind:
        assert a[k].seed == b[k].seed
        np.testing.assert_array_equal(a[k].predictions, b[k].predictions)


@pytest.mark.usefixtures("small_forests")
def test_folds_in_parallel_give_the_same_predictions():
    X, y, g = cohort(3, n_classes=3, informative=False)  # noise: predictions depend on each forest's draws
    one = evaluate_classifiers(X, y, g, rng=np.random.default_rng(4))
    with parallel_config(n_jobs=2):
        two = evaluate_classifiers(X, y, g, rng=np.random.default_rng(4))
    for k in ClassifierKind:
        np.testing.assert_array_equal(one[k].predictions, two[k].predictions)


def test_classifier_configuration():
    tree = make_classifier(ClassifierKind.DECISION_TREE, seed=1)[-1]
    assert tree.criterion == "entropy" and tree.ccp_alpha > 0 and tree.min_samples_leaf == 2
    assert make_classifier(ClassifierKind.RANDOM_FOREST, seed=1)[-1].n_estimators == 100
    svm = make_classifier(ClassifierKind.SVM, seed=1)
    assert [name for name, _ in svm.steps] == ["impute", "scale", "svm"]


@pytest.mark.parametrize("method", list(RankingMethod))
def test_ranking_puts_informative_features_first(method):
    X, y, _ = cohort(9)
    names = tuple(f"f{i}" for i in range(8))
    r = rank_features(X, y, names, rng=np.random.default_rng(0), method=method)
    assert set(r.names[:2]) == {"f0", "f1"}
    assert np.all(np.diff(r.scores) <= 0) and sorted(r.names) == sorted(names)


def test_bad_input():
    X, y, g = cohort(0)
    rng = np.random.default_rng(0)
    with pytest.raises(BadInputError):
        evaluate_classifiers(X[:-1], y, g, rng=rng)
    with pytest.raises(BadInputError):
        evaluate_classifiers(X, np.zeros_like(y), g, rng=rng)
    with pytest.raises(BadInputError):
        loso_folds(np.full(5, "a"))
    with pytest.raises(BadInputError):
        rank_features(X, y, ("a",), rng=rng)


def test_welch_t_tests_match_scipy_and_markdown():
    rng = np.random.default_rng(0)
    v = rng.normal(size=(30, 2))
    in_a = np.arange(30) < 12
    v[in_a, 0] += 1.0
    v[3, 1] = np.nan
    res = welch_t_tests(v, in_a, ["trunk", "tilt"])
    ref = stats.ttest_ind(v[in_a, 0], v[~in_a, 0], equal_var=False)
    assert res[0].t == pytest.approx(ref.statistic) and res[0].p == pytest.approx(ref.pvalue)
    assert (res[0].n_a, res[0].n_b, res[1].n_a) == (12, 18, 11)
    assert res[0].mean_a == pytest.approx(v[in_a, 0].mean())
    md = t_tests_markdown(res)
    assert md.count("\n") == 4 and "| trunk |" in md and "patients" in md
    one = welch_t_tests(v[:13], np.arange(13) < 12, ["trunk", "tilt"])
    assert np.isnan(one[0].t) and np.isnan(one[0].p)
    with pytest.raises(BadInputError):
        welch_t_tests(v, in_a.astype(int), ["trunk", "tilt"])


def test_compensation_measures_on_a_leaning_trunk():
    T = 21
    pos = np.zeros((T, KINECT_V2.n_joints, 3))
    lean = np.linspace(0, np.radians(10), T)
    mid, chest = KINECT_V2.index(Landmark.SPINE_MID), KINECT_V2.index(Landmark.SPINE_SHOULDER)
    pos[:, mid] = (0, 0, 1.1)
    pos[:, chest] = np.stack([np.zeros(T), 0.3 * np.sin(lean), 1.1 + 0.3 * np.cos(lean)], axis=1)
    pos[:, KINECT_V2.index(Landmark.SHOULDER_RIGHT), 2] = 1.4 + np.linspace(0, 0.02, T)
    c = compensation_measures(pos, KINECT_V2, "right", RepetitionSegment(0, 10, T - 1, 0.0, 2.0))
    assert len(COMPENSATION_NAMES) == c.size == 3
    np.testing.assert_allclose(c, [0.3 * np.sin(np.radians(10)), 10.0, 0.02], atol=1e-9)


def test_a_fold_left_with_one_class_is_refused_by_name():
    X = np.arange(12, dtype=float).reshape(6, 2)
    y = np.array([0, 0, 1, 1, 1, 1])  # subject a is the only one of class 0
    groups = np.array(["a", "a", "b", "b", "c", "c"])
    model = make_classifier(ClassifierKind.DECISION_TREE, seed=0)
    with pytest.raises(BadInputError, match="leaving subject a out leaves only the class"):
        out_of_fold_predictions(model, X, y, loso_folds(groups))
