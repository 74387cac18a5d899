"""Severity regression: the FMA-UE score of a subject from the features of its repetitions.

A seeded random-forest regressor (as many trees as the classifiers, :data:`fma.classify.N_TREES`;
median imputation of NaN features fitted on the training fold) is scored by leave-one-subject-out
validation: every subject's repetitions are predicted by a model that never saw that subject, and
the subject's prediction is the mean over its repetitions. Metrics are per subject: mean absolute
error (points) and Pearson's correlation between predicted and true scores.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats
from sklearn.ensemble import RandomForestRegressor
from sklearn.impute import SimpleImputer
from sklearn.pipeline import Pipeline

from fma import classify
from fma.classify import loso_folds, out_of_fold_predictions
from fusion.errors import BadInputError


@dataclass(frozen=True)
class SeverityResult:
    """Leave-one-subject-out severity regression.

    Attributes
    ----------
    subjects : np.ndarray
        (S,) subject ids, sorted.
    truth : np.ndarray
        (S,) true scores, points.
    predicted : np.ndarray
        (S,) mean out-of-fold prediction over each subject's samples, points.
    mae : float
        Mean absolute error over the subjects, points.
    correlation : float
        Pearson correlation of ``predicted`` and ``truth`` (NaN when either is constant).
    baseline_mae : float
        MAE of predicting each held-out subject with the mean score of the other subjects.
    seed : int
        ``random_state`` of the forest.
    """

    subjects: np.ndarray
    truth: np.ndarray
    predicted: np.ndarray
    mae: float
    correlation: float
    baseline_mae: float
    seed: int


def regress_severity(X: np.ndarray, scores: np.ndarray, subjects: np.ndarray, *,
                     rng: np.random.Generator) -> SeverityResult:
    """Predict each subject's score from (N, F) features ``X`` of its N samples, leaving it out.

    Parameters
    ----------
    X : np.ndarray
        (N, F) features, NaN allowed.
    scores : np.ndarray
        (N,) score of each sample's subject (the same for all of a subject's samples), points.
    subjects : np.ndarray
        (N,) subject of each sample; at least three subjects.
    rng : np.random.Generator
        Source of the forest's ``random_state``.

    Returns
    -------
    SeverityResult
    """
    X = np.asarray(X, dtype=float)
    y = np.asarray(scores, dtype=float)
    g = np.asarray(subjects).astype(str)
    if X.ndim != 2 or y.shape != (X.shape[0],) or g.shape != (X.shape[0],):
        raise BadInputError(f"X must be (N, F), scores and subjects (N,); got {X.shape}, {y.shape}, {g.shape}")
    if not np.all(np.isfinite(y)) or np.any(np.isinf(X)):
        raise BadInputError("scores must be finite and X must not hold infinite values")
    names = np.unique(g)
    if names.size < 3:
        raise BadInputError(f"severity regression needs at least three subjects, got {names.size}")
    per_subject = {n: np.unique(y[g == n]) for n in names}
    if any(v.size != 1 for v in per_subject.values()):
        raise BadInputError("every sample of a subject must carry that subject's one score")
    seed = int(rng.integers(2**31 - 1))
    model = Pipeline([("impute", SimpleImputer(strategy="median", keep_empty_features=True)),
                      ("forest", RandomForestRegressor(n_estimators=classify.N_TREES, random_state=seed))])
    folds = loso_folds(g)
    pred = out_of_fold_predictions(model, X, y, folds)
    baseline = {fold.test_group: float(np.mean([per_subject[n][0] for n in names if n != fold.test_group]))
                for fold in folds}
    truth = np.array([per_subject[n][0] for n in names])
    predicted = np.array([pred[g == n].mean() for n in names])
    constant = np.ptp(truth) == 0 or np.ptp(predicted) == 0
    r = float("nan") if constant else float(stats.pearsonr(predicted, truth)[0])
    base = float(np.mean([abs(baseline[n] - t) for n, t in zip(names, truth)]))
    return SeverityResult(names, truth, predicted, float(np.mean(np.abs(predicted - truth))), r, base, seed)
