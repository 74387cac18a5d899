"""Person-level group comparisons: person means, Welch on person means, mixed model, Hedges' g."""

import numpy as np
import pytest

from fma.statistics import (
    hedges_g,
    person_level_tests,
    person_means,
    person_tests_markdown,
    welch_t_tests,
)
from fusion.errors import BadInputError

REPS = 30


def _cohort(offsets_a, offsets_b, shift=0.0):
    """Repetition values: each person's offset plus small deterministic within-person noise."""
    noise = np.linspace(-0.1, 0.1, REPS)
    values, in_a, subjects = [], [], []
    for group, offsets in (("a", offsets_a), ("b", offsets_b)):
        for i, off in enumerate(offsets):
            values += list(off + (shift if group == "a" else 0.0) + noise)
            in_a += [group == "a"] * REPS
            subjects += [f"{group}{i}"] * REPS
    return np.array(values)[:, None], np.array(in_a), np.array(subjects)


OFFSETS_A = [2.0, -1.0, 1.5, 0.5]
OFFSETS_B = [-0.5, 1.0, -2.0, 0.0]


def test_person_means_match_a_hand_computation():
    values = np.array([[1.0, 10.0], [3.0, np.nan], [5.0, 20.0], [np.nan, np.nan], [7.0, 1.0]])
    persons, means = person_means(values, np.array(["p", "p", "q", "q", "r"]))
    assert persons.tolist() == ["p", "q", "r"]
    np.testing.assert_allclose(means, [[2.0, 10.0], [5.0, 20.0], [7.0, 1.0]])
    _, empty = person_means(np.array([[np.nan]]), np.array(["p"]))
    assert np.isnan(empty).all()


def test_pseudo_replication_is_caught_by_the_person_level_test():
    values, in_a, subjects = _cohort(OFFSETS_A, OFFSETS_B)
    (rep,) = welch_t_tests(values, in_a, ["x"])
    (person,) = person_level_tests(values, in_a, subjects, ["x"])
    assert rep.p < 1e-3 and rep.n_a == 4 * REPS
    assert person.p > 0.1 and person.n_persons_a == person.n_persons_b == 4
    assert person.lmm_ok and person.lmm_p > 0.05
    assert person.mean_a == pytest.approx(np.mean(OFFSETS_A)) and person.mean_b == pytest.approx(np.mean(OFFSETS_B))


def test_a_real_difference_is_found_by_both():
    values, in_a, subjects = _cohort(OFFSETS_A, OFFSETS_B, shift=10.0)
    (rep,) = welch_t_tests(values, in_a, ["x"])
    (person,) = person_level_tests(values, in_a, subjects, ["x"])
    assert rep.p < 1e-6 and person.p < 1e-3
    assert person.lmm_ok and person.lmm_p < 1e-3
    assert person.lmm_effect == pytest.approx(10.0 + np.mean(OFFSETS_A) - np.mean(OFFSETS_B), abs=1e-6)
    assert person.hedges_g > 3 and person.g_low > 0


def test_hedges_g_interval_contains_the_true_effect():
    rng = np.random.default_rng(1)
    a, b = rng.normal(1.0, 1.0, 40), rng.normal(0.0, 1.0, 40)
    values = np.concatenate([a, b])[:, None]
    in_a = np.arange(80) < 40
    (r,) = person_level_tests(values, in_a, np.array([f"s{i}" for i in range(80)]), ["x"], n_boot=500)
    assert r.g_low < 1.0 < r.g_high and r.g_low < r.hedges_g < r.g_high
    assert r.hedges_g == pytest.approx(hedges_g(a, b))
    again = person_level_tests(values, in_a, np.array([f"s{i}" for i in range(80)]), ["x"], n_boot=500)
    assert again == [r]


def test_failures_give_nan_not_an_exception():
    values, in_a, subjects = _cohort(OFFSETS_A, OFFSETS_B)
    values = np.column_stack([values, np.full(values.shape[0], np.nan)])
    good, empty = person_level_tests(values, in_a, subjects, ["x", "nan"])
    assert good.lmm_ok
    assert not empty.lmm_ok and empty.lmm_note and np.isnan([empty.lmm_p, empty.lmm_effect, empty.p]).all()
    assert empty.n_persons_a == 0 and np.isnan(empty.hedges_g)
    one, in_a1, subj1 = _cohort([1.0], [0.0])
    (r,) = person_level_tests(one, in_a1, subj1, ["x"])
    assert not r.lmm_ok and np.isnan([r.lmm_p, r.p, r.hedges_g, r.g_low]).all()
    assert "n/a" in person_tests_markdown([r, empty, good])


def test_bad_shapes_are_refused():
    values, in_a, subjects = _cohort(OFFSETS_A, OFFSETS_B)
    with pytest.raises(BadInputError):
        person_level_tests(values, in_a, subjects[:-1], ["x"])
    with pytest.raises(BadInputError):
        person_level_tests(values, in_a.astype(int), subjects, ["x"])
    with pytest.raises(BadInputError):
        person_level_tests(values, in_a, subjects, ["x", "y"])
    with pytest.raises(BadInputError):
        person_level_tests(values[:, 0], in_a, subjects, ["x"])
    with pytest.raises(BadInputError, match="both groups"):
        person_level_tests(values, in_a, np.where(subjects == "b0", "a0", subjects), ["x"])
    with pytest.raises(BadInputError):
        person_means(values, subjects[:3])
