"""Leave-one-subject-out classification and feature ranking (section 4 of the paper).

Classifiers (:class:`ClassifierKind`):

- ``DECISION_TREE``: a C4.5-like tree, ``DecisionTreeClassifier(criterion="entropy",
  min_samples_leaf=2, ccp_alpha=0.01)``. Weka J48 prunes with a pessimistic error bound at
  confidence factor 0.25, which scikit-learn lacks. ``min_samples_leaf=2`` is J48's default minimum
  leaf size (``-M 2``); minimal cost-complexity pruning with ``ccp_alpha=0.01`` removes every subtree
  whose sample-weighted entropy reduction (bits) is below 0.01 per extra leaf, about 1 % of a
  balanced binary root's entropy. On cohorts of tens to hundreds of samples this removes the same
  kind of small, noise-fitting subtrees as CF 0.25; it approximates J48, it is not its algorithm.
- ``RANDOM_FOREST``: 100 trees, seeded.
- ``SVM``: ``StandardScaler`` then an RBF ``SVC`` (C = 1, gamma "scale").

Every classifier is a ``Pipeline`` that first imputes NaN features with the training fold's median
(all-NaN features become 0). Labels may be binary (patient / healthy) or multi-class (item scores
0/1/2): the same code handles both.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np
from joblib import Parallel, delayed
from sklearn.base import clone
from sklearn.ensemble import RandomForestClassifier
from sklearn.feature_selection import mutual_info_classif
from sklearn.impute import SimpleImputer
from sklearn.metrics import confusion_matrix
from sklearn.model_selection import LeaveOneGroupOut
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.svm import SVC
from sklearn.tree import DecisionTreeClassifier

from fusion.errors import BadInputError

C45_MIN_SAMPLES_LEAF = 2
C45_CCP_ALPHA = 0.01
N_TREES = 100


class ClassifierKind(enum.Enum):
    """The paper's three classifiers."""

    DECISION_TREE = "decision_tree"
    RANDOM_FOREST = "random_forest"
    SVM = "svm"


class RankingMethod(enum.Enum):
    """Feature ranking by information gain (mutual information) or random-forest importance."""

    INFORMATION_GAIN = "information_gain"
    FOREST_IMPORTANCE = "forest_importance"


def _imputer() -> SimpleImputer:
    return SimpleImputer(strategy="median", keep_empty_features=True)


def make_classifier(kind: ClassifierKind, *, seed: int) -> Pipeline:
    """An unfitted scikit-learn pipeline (median imputation + classifier) with ``random_state=seed``."""
    if kind is ClassifierKind.DECISION_TREE:
        steps = [("tree", DecisionTreeClassifier(criterion="entropy", min_samples_leaf=C45_MIN_SAMPLES_LEAF,
                                                 ccp_alpha=C45_CCP_ALPHA, random_state=seed))]
    elif kind is ClassifierKind.RANDOM_FOREST:
        steps = [("forest", RandomForestClassifier(n_estimators=N_TREES, random_state=seed))]
    elif kind is ClassifierKind.SVM:
        steps = [("scale", StandardScaler()), ("svm", SVC(kernel="rbf", C=1.0, gamma="scale", random_state=seed))]
    else:
        raise BadInputError(f"unknown classifier {kind!r}; available: {[k.value for k in ClassifierKind]}")
    return Pipeline([("impute", _imputer())] + steps)


@dataclass(frozen=True)
class Fold:
    """One leave-one-subject-out fold: sample indices and the held-out subject."""

    train_index: np.ndarray
    test_index: np.ndarray
    test_group: str


@dataclass(frozen=True)
class ClassifierResult:
    """Cross-validated performance of one classifier.

    Attributes
    ----------
    kind : ClassifierKind
    accuracy : float
        Fraction of samples predicted correctly over all folds.
    classes : np.ndarray
        (K,) sorted class labels; rows (truth) and columns (prediction) of ``confusion``.
    confusion : np.ndarray
        (K, K) int counts.
    predictions : np.ndarray
        (N,) out-of-fold predicted label of every sample.
    folds : tuple of Fold
        The splits, one per subject.
    seed : int
        ``random_state`` given to the classifier.
    """

    kind: ClassifierKind
    accuracy: float
    classes: np.ndarray
    confusion: np.ndarray
    predictions: np.ndarray
    folds: tuple[Fold, ...]
    seed: int


def _check_xyg(X: np.ndarray, y: np.ndarray, groups: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    X, y, g = np.asarray(X, dtype=float), np.asarray(y), np.asarray(groups).astype(str)
    if X.ndim != 2 or y.shape != (X.shape[0],) or g.shape != (X.shape[0],):
        raise BadInputError(f"X must be (N, F), y and groups (N,); got {X.shape}, {y.shape}, {g.shape}")
    if np.any(np.isinf(X)):
        raise BadInputError("X contains infinite values")
    if np.unique(y).size < 2:
        raise BadInputError("y needs at least two classes")
    return X, y, g


def loso_folds(groups: np.ndarray) -> tuple[Fold, ...]:
    """Leave-one-subject-out splits of (N,) group labels; needs at least two subjects."""
    g = np.asarray(groups).astype(str)
    if np.unique(g).size < 2:
        raise BadInputError("leave-one-subject-out needs at least two subjects")
    splits = LeaveOneGroupOut().split(np.zeros((g.size, 1)), groups=g)
    return tuple(Fold(tr, te, str(g[te[0]])) for tr, te in splits)


def _fit_predict(model: Pipeline, X: np.ndarray, y: np.ndarray, fold: Fold) -> np.ndarray:
    """Predictions for ``fold``'s held-out samples of a clone of ``model`` fitted on its training samples."""
    return clone(model).fit(X[fold.train_index], y[fold.train_index]).predict(X[fold.test_index])


def out_of_fold_predictions(model: Pipeline, X: np.ndarray, y: np.ndarray, folds: tuple[Fold, ...]) -> np.ndarray:
    """(N,) prediction of every sample by a clone of ``model`` fitted without its fold.

    The folds run in parallel under ``joblib.parallel_config(n_jobs=...)`` (one at a time by
    default); the predictions do not depend on it.
    """
    pred = np.empty_like(y)
    for fold in folds:
        if np.unique(y[fold.train_index]).size < 2:
            left = np.unique(y[fold.train_index])
            raise BadInputError(f"leaving subject {fold.test_group} out leaves only the class(es) {list(map(str, left))} "
                                "to train on; leave-one-subject-out needs at least two subjects of each class")
    fold_predictions = Parallel()(delayed(_fit_predict)(model, X, y, fold) for fold in folds)
    for fold, fold_pred in zip(folds, fold_predictions, strict=True):
        pred[fold.test_index] = fold_pred
    return pred


def evaluate_classifiers(
    X: np.ndarray,
    y: np.ndarray,
    groups: np.ndarray,
    *,
    rng: np.random.Generator,
    kinds: tuple[ClassifierKind, ...] = tuple(ClassifierKind),
) -> dict[ClassifierKind, ClassifierResult]:
    """Leave-one-subject-out cross-validation of each classifier.

    Parameters
    ----------
    X : np.ndarray
        (N, F) features (NaN allowed; imputed per training fold).
    y : np.ndarray
        (N,) int labels, two or more classes (patient/healthy, or item scores 0/1/2).
    groups : np.ndarray
        (N,) subject of each sample; all of a subject's samples are held out together.
    rng : np.random.Generator
        Source of one ``random_state`` per classifier (the same for all its folds).
    kinds : tuple of ClassifierKind
        Classifiers to run.

    Returns
    -------
    dict
        :class:`ClassifierKind` -> :class:`ClassifierResult`.
    """
    X, y, g = _check_xyg(X, y, groups)
    folds = loso_folds(g)
    classes = np.unique(y)
    results = {}
    for kind in kinds:
        seed = int(rng.integers(2**31 - 1))
        pred = out_of_fold_predictions(make_classifier(kind, seed=seed), X, y, folds)
        results[kind] = ClassifierResult(kind, float(np.mean(pred == y)), classes,
                                         confusion_matrix(y, pred, labels=classes), pred, folds, seed)
    return results


@dataclass(frozen=True)
class FeatureRanking:
    """Features ordered from most to least informative.

    Attributes
    ----------
    method : RankingMethod
    names : tuple of str
        Feature names, best first.
    scores : np.ndarray
        (F,) matching scores (mutual information in nats, or mean decrease in impurity summing to 1).
    """

    method: RankingMethod
    names: tuple[str, ...]
    scores: np.ndarray


def rank_features(
    X: np.ndarray,
    y: np.ndarray,
    names: tuple[str, ...],
    *,
    rng: np.random.Generator,
    method: RankingMethod = RankingMethod.INFORMATION_GAIN,
) -> FeatureRanking:
    """Rank the F features of (N, F) ``X`` for predicting (N,) ``y`` on all the data.

    NaN features are median-imputed first. Information gain is scikit-learn's k-NN mutual
    information estimate (``mutual_info_classif``), seeded from ``rng``; forest importance is the
    impurity-based importance of a seeded 100-tree random forest. Ties keep the input order.
    """
    X = np.asarray(X, dtype=float)
    y = np.asarray(y)
    if X.ndim != 2 or X.shape[1] != len(names) or y.shape != (X.shape[0],):
        raise BadInputError(f"X must be (N, {len(names)}) and y (N,); got {X.shape} and {y.shape}")
    Xi = _imputer().fit_transform(X)
    seed = int(rng.integers(2**31 - 1))
    if method is RankingMethod.INFORMATION_GAIN:
        scores = mutual_info_classif(Xi, y, random_state=seed)
    elif method is RankingMethod.FOREST_IMPORTANCE:
        scores = RandomForestClassifier(n_estimators=N_TREES, random_state=seed).fit(Xi, y).feature_importances_
    else:
        raise BadInputError(f"unknown ranking method {method!r}")
    order = np.argsort(-scores, kind="stable")
    return FeatureRanking(method, tuple(names[i] for i in order), scores[order])


@dataclass(frozen=True)
class ClassMetrics:
    """Balanced scores of out-of-fold predictions.

    Attributes
    ----------
    classes : np.ndarray
        (K,) class labels, sorted.
    recall : np.ndarray
        (K,) fraction of each true class predicted as itself (NaN for a class with no sample).
    f1 : np.ndarray
        (K,) F1 score of each class (0 when the class is never predicted nor present correctly).
    macro_f1 : float
        Mean of ``f1`` over the classes present in the truth.
    balanced_accuracy : float
        Mean of ``recall`` over the classes present in the truth.
    confusion : np.ndarray
        (K, K) int counts, rows truth, columns prediction.
    """

    classes: np.ndarray
    recall: np.ndarray
    f1: np.ndarray
    macro_f1: float
    balanced_accuracy: float
    confusion: np.ndarray


def class_metrics(y_true: np.ndarray, y_pred: np.ndarray, classes: np.ndarray | None = None) -> ClassMetrics:
    """Per-class recall and F1, macro-F1 and balanced accuracy of (N,) predictions against (N,) truth.

    ``classes`` (default: the union of both label sets) fixes the rows and columns of the confusion
    matrix; classes absent from the truth are left out of the macro averages.
    """
    t, p = np.asarray(y_true), np.asarray(y_pred)
    if t.ndim != 1 or t.shape != p.shape or t.size == 0:
        raise BadInputError(f"y_true and y_pred must be equal-length non-empty (N,) arrays, got {t.shape} and {p.shape}")
    labels = np.unique(np.concatenate([t, p])) if classes is None else np.asarray(classes)
    cm = confusion_matrix(t, p, labels=labels)
    support, predicted, hits = cm.sum(axis=1), cm.sum(axis=0), np.diag(cm)
    with np.errstate(invalid="ignore", divide="ignore"):
        recall = np.where(support > 0, hits / support, np.nan)
        precision = np.where(predicted > 0, hits / predicted, 0.0)
        f1 = np.where(hits > 0, 2 * precision * np.nan_to_num(recall) / (precision + np.nan_to_num(recall)), 0.0)
    present = support > 0
    return ClassMetrics(labels, recall, f1, float(np.mean(f1[present])), float(np.mean(recall[present])), cm)
