"""How far a leave-one-subject-out accuracy of ``mocap-bench fma`` can be trusted: the chance level
of the evaluated samples and warnings about folds too small to mean much."""

from __future__ import annotations

import numpy as np

MIN_SUBJECTS_PER_CLASS = 5
"""Below this many subjects in a class, the report warns that the accuracies are unreliable."""


def chance_level(labels: np.ndarray) -> float:
    """Share (0-1) of the majority class among (N,) evaluated labels: the accuracy of always
    guessing it; NaN for no labels."""
    y = np.asarray(labels)
    if y.size == 0:
        return float("nan")
    return float(np.unique(y, return_counts=True)[1].max() / y.size)


def loso_warnings(labels: np.ndarray, subjects: np.ndarray, scope: str) -> list[str]:
    """Warnings (plain sentences) about leave-one-subject-out folds of (N,) ``labels`` grouped by (N,)
    ``subjects``: a class with fewer than :data:`MIN_SUBJECTS_PER_CLASS` subjects, and folds whose
    training set lacks a class. ``scope`` names the analysis in each sentence."""
    y, s = np.asarray(labels), np.asarray(subjects).astype(str)
    classes = np.unique(y)
    out = []
    counts = {c: np.unique(s[y == c]).size for c in classes.tolist()}
    if min(counts.values(), default=0) < MIN_SUBJECTS_PER_CLASS:
        per = ", ".join(f"class {c}: {n}" for c, n in counts.items())
        out.append(f"{scope}: fewer than {MIN_SUBJECTS_PER_CLASS} subjects per class ({per}); with leave-one-subject-out "
                   "each fold trains on the few remaining subjects, whose class balance flips against the held-out one, so "
                   "an accuracy far below the chance level (even 0 %) is an artefact of the split, not a finding, and "
                   "every accuracy here moves by tens of points from cohort to cohort.")
    lacking = {}
    for subject in np.unique(s).tolist():
        missing = np.setdiff1d(classes, np.unique(y[s != subject])).tolist()
        if missing:
            lacking[subject] = missing
    if lacking:
        where = "; ".join(f"without {k}: class {v}" for k, v in lacking.items())
        out.append(f"{scope}: in {len(lacking)} fold(s) the training set lacks a class ({where}); the held-out subject's "
                   "samples of that class can never be predicted correctly, which lowers the accuracy by construction.")
    return out
