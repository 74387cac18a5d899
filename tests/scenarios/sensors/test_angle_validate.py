"""angle-validate and the arm-bias fit: episode discovery in a made-up UI-PRMD tree, the stand-in
camera, the agreement thresholds, compare and summarise on a synthetic pair, and the fit recovering
known coefficients."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

from fusion.errors import BadInputError
from fusion.transforms import make_transform
from scenarios.cli import main
from scenarios.sensors.angle_validate import (
    STATISTICS,
    Episode,
    EpisodeResult,
    agree_chance,
    agrees,
    compare,
    find_episodes,
    people_interval,
    summarise,
)
from scenarios.sensors.angle_validate_run import validate_dataset
from scenarios.sensors.fit_arm_bias import (
    GROSS_M,
    EpisodeOffsets,
    fit_arm_bias,
    person_coefficients,
    person_modes,
    with_arm_bias,
)
from scenarios.sensors.replica import camera_stand_in
from sim.rig import look_at
from sim.sensor_profile import load_profile, profile_from_dict, profile_to_toml
from tests.fusion.merge.test_episode_alignment import episode_pair

# --------------------------------------------------------------------------------------------------
# find_episodes


KINECT_ONLY = "m07_s03_e01"
NAMES = ["m07_s01_e01", "m07_s01_e02", "m07_s01_e03", "m07_s02_e01", "m08_s01_e01", "m10_s02_e02",
         "m01_s01_e01"]


def _touch(path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"")


@pytest.fixture
def dataset(tmp_path: Path) -> Path:
    """A UI-PRMD-shaped tree of empty positions files (both systems, and one Kinect-only episode)."""
    root = tmp_path / "UI-PRMD"
    for split, suffix, names in (("Segmented Movements", "", NAMES),
                                 ("Incorrect Segmented Movements", "_inc", ["m07_s01_e01", "m09_s02_e04"])):
        for name in names:
            for system in ("Kinect", "Vicon"):
                _touch(root / split / system / "Positions" / f"{name}_positions{suffix}.txt.gz")
    _touch(root / "Segmented Movements" / "Kinect" / "Positions" / f"{KINECT_ONLY}_positions.txt.gz")
    _touch(root / "Segmented Movements" / "Kinect" / "Positions" / "notes.txt")
    _touch(root / "Segmented Movements" / "Kinect" / "Angles" / "m07_s01_e01_angles.txt.gz")
    return root


def test_find_episodes_default_is_the_shoulder_movements_with_both_systems(dataset):
    found = find_episodes(dataset)
    assert [e.name for e in found] == ["m07_s01_e01", "m07_s01_e02", "m07_s01_e03", "m07_s02_e01",
                                       "m08_s01_e01", "m10_s02_e02"]
    e = found[0]
    assert (e.movement, e.subject, e.number, e.incorrect) == ("m07", "s01", 1, False)
    split = dataset / "Segmented Movements"
    assert e.kinect == split / "Kinect" / "Positions" / "m07_s01_e01_positions.txt.gz"
    assert e.vicon == split / "Vicon" / "Positions" / "m07_s01_e01_positions.txt.gz"
    # the split folder itself works too
    assert [x.name for x in find_episodes(split)] == [x.name for x in found]


def test_simulation_seeds_give_each_subject_its_own_people_and_each_episode_its_sessions():
    """A subject is the same simulated person in all its episodes (per seed), two subjects are not,
    and no two episodes share a session: the simulated means pool subjects times seeds people."""
    def ep(movement, subject, number):
        return Episode(movement, subject, number, Path("k"), Path("v"))

    a1, a2, b1 = ep("m07", "s01", 1), ep("m10", "s01", 4), ep("m07", "s02", 1)
    assert a1.simulation_seeds(0)[1] == a2.simulation_seeds(0)[1]
    assert a1.simulation_seeds(0)[1] != b1.simulation_seeds(0)[1]
    assert a1.simulation_seeds(0)[1] != a1.simulation_seeds(1)[1]
    sessions = {e.simulation_seeds(s)[0] for e in (a1, a2, b1) for s in (0, 1)}
    assert len(sessions) == 6
    assert a1.simulation_seeds(0) == ep("m07", "s01", 1).simulation_seeds(0)  # stable


def test_find_episodes_filters_subjects_and_movements(dataset):
    assert [e.name for e in find_episodes(dataset, ["s02"])] == ["m07_s02_e01", "m10_s02_e02"]
    assert [e.name for e in find_episodes(dataset, None, ["m08", "m10"])] == ["m08_s01_e01", "m10_s02_e02"]
    assert [e.name for e in find_episodes(dataset, ["s01"], ["m07"])] == ["m07_s01_e01", "m07_s01_e02",
                                                                          "m07_s01_e03"]
    # a movement asked for by name is found even outside the shoulder movements
    assert [e.name for e in find_episodes(dataset, movements=["m01"])] == ["m01_s01_e01"]


def test_find_episodes_limit_per_movement_and_subject(dataset):
    assert [e.name for e in find_episodes(dataset, limit=1)] == ["m07_s01_e01", "m07_s02_e01", "m08_s01_e01",
                                                                 "m10_s02_e02"]
    assert [e.name for e in find_episodes(dataset, ["s01"], ["m07"], limit=2)] == ["m07_s01_e01", "m07_s01_e02"]


def test_find_episodes_refuses_missing_subjects_and_movements_by_name(dataset):
    with pytest.raises(BadInputError, match="subject.*s05"):
        find_episodes(dataset, ["s01", "s05"])
    with pytest.raises(BadInputError, match="subject.*s03"):  # Kinect file only: no pair
        find_episodes(dataset, ["s03"])
    with pytest.raises(BadInputError, match="movement.*m09"):
        find_episodes(dataset, None, ["m07", "m09"])


def test_find_episodes_refuses_a_folder_that_is_not_ui_prmd(tmp_path, dataset):
    (tmp_path / "other" / "Kinect").mkdir(parents=True)
    with pytest.raises(BadInputError, match="Segmented Movements"):
        find_episodes(tmp_path / "other")
    (dataset / "Incorrect Segmented Movements" / "Vicon").rename(dataset / "elsewhere")
    with pytest.raises(BadInputError, match="Incorrect Segmented Movements"):
        find_episodes(dataset, incorrect=True)


def test_find_episodes_incorrect_movements(dataset):
    found = find_episodes(dataset, incorrect=True)
    assert [e.name for e in found] == ["m07_s01_e01_inc", "m09_s02_e04_inc"]
    assert all(e.incorrect for e in found)
    split = dataset / "Incorrect Segmented Movements"
    assert found[0].kinect == split / "Kinect" / "Positions" / "m07_s01_e01_positions_inc.txt.gz"
    assert found[0].vicon == split / "Vicon" / "Positions" / "m07_s01_e01_positions_inc.txt.gz"
    assert [e.name for e in find_episodes(dataset, ["s02"], incorrect=True)] == ["m09_s02_e04_inc"]


# --------------------------------------------------------------------------------------------------
# camera_stand_in


def _column(z_low: float, z_high: float, x: float = 0.0) -> np.ndarray:
    z = np.linspace(z_low, z_high, 20)
    return np.stack([np.full_like(z, x), np.zeros_like(z), z], axis=-1)


@pytest.mark.parametrize("position, target", [
    ([3.0, 0.5, 2.0], [0.0, 0.0, 0.5]),  # looking down
    ([2.5, -1.0, 0.3], [0.0, 0.2, 1.4]),  # looking up, from the side
])
def test_camera_stand_in_looks_level_at_the_height_centring_the_joints(position, target):
    T = look_at(position, target)
    joints = _column(0.0, 1.8)[None].repeat(3, axis=0)
    joints[1, 4] = np.nan
    cam = camera_stand_in(T, joints)
    p, q = np.asarray(cam.position_m), np.asarray(cam.target_m)
    np.testing.assert_allclose(p[:2], position[:2], atol=1e-12)
    assert q[2] == pytest.approx(p[2])  # level
    ahead = np.asarray(target, dtype=float)[:2] - np.asarray(position, dtype=float)[:2]
    np.testing.assert_allclose(q[:2] - p[:2], ahead / np.linalg.norm(ahead), atol=1e-9)
    assert p[2] == pytest.approx(0.9, abs=0.011)  # the joints span 0 to 1.8 m at one depth
    assert cam.up_m == [0.0, 0.0, 1.0]


def test_camera_stand_in_height_follows_the_joints():
    T = look_at([3.0, 0.0, 1.0], [0.0, 0.0, 1.0])
    assert camera_stand_in(T, _column(1.0, 2.0)).position_m[2] == pytest.approx(1.5, abs=0.011)
    assert camera_stand_in(T, _column(0.2, 0.6)).position_m[2] == pytest.approx(0.4, abs=0.011)


def test_camera_stand_in_refusals():
    down = make_transform(np.column_stack([[1.0, 0, 0], [0, -1.0, 0], [0, 0, -1.0]]), np.array([0.0, 0.0, 3.0]))
    with pytest.raises(BadInputError, match="straight up or down"):
        camera_stand_in(down, _column(0.0, 1.8))
    with pytest.raises(BadInputError, match="no joint"):
        camera_stand_in(look_at([3.0, 0.0, 1.0], [0.0, 0.0, 1.0]), np.full((4, 25, 3), np.nan))


# --------------------------------------------------------------------------------------------------
# agrees, compare, summarise


@pytest.mark.parametrize("statistic", STATISTICS[:3])
@pytest.mark.parametrize("real, sim, expected", [
    (1.0, 3.9, True), (1.0, 4.1, False), (1.0, -1.9, True), (0.0, -3.1, False),  # 3 deg floor
    (20.0, 25.9, True), (20.0, 26.1, False), (-20.0, -14.1, True), (-20.0, -13.9, False),  # 30 %
    (np.nan, 1.0, False), (1.0, np.nan, False), (np.inf, np.inf, False),
])
def test_agrees_for_signed_errors(statistic, real, sim, expected):
    assert agrees(statistic, real, sim) is expected


@pytest.mark.parametrize("real, sim, expected", [
    (10.0, 12.9, True), (10.0, 7.1, True), (10.0, 13.1, False), (10.0, 6.9, False),
    (2.0, 4.5, False),  # no 3 deg floor for the trace RMSE
    (2.0, 2.5, True), (np.nan, 2.0, False),
])
def test_agrees_for_the_trace_rmse(real, sim, expected):
    assert agrees("elevation_trace_rmse_deg", real, sim) is expected


@pytest.fixture(scope="module")
def side():
    """:func:`compare` of a synthetic optical stream and a shifted, moved Kinect copy of it."""
    vicon, kinect = episode_pair()
    return compare(vicon, kinect)


def test_compare_a_copy_gives_near_zero_errors(side):
    assert side.alignment.ok and side.alignment.side == "right" and side.errors is not None
    for stat in STATISTICS:
        assert abs(side.value(stat)) < 0.5
    both = np.isfinite(side.elevation_deg) & np.isfinite(side.truth_elevation_deg)
    assert both.sum() > 60 and side.times.shape == side.elevation_deg.shape
    assert np.abs(side.elevation_deg[both] - side.truth_elevation_deg[both]).max() < 1.0
    assert np.nanmax(side.truth_elevation_deg) > 100.0


def test_summarise_pools_seeds_per_movement(side, tmp_path):
    def result(movement: str, number: int, sims: int) -> EpisodeResult:
        episode = Episode(movement, "s01", number, tmp_path / "k", tmp_path / "v")
        return EpisodeResult(episode, side, (side,) * sims, "" if sims else "not simulated")

    summary = summarise([result("m07", 1, 2), result("m07", 2, 2), result("m10", 1, 0)])
    assert sorted(summary["movements"]) == ["m07", "m10"]
    row = summary["movements"]["m07"]["peak_elevation_error_deg"]
    assert row["real_n"] == 2 and row["sim_n"] == 4
    assert row["real_mean"] == pytest.approx(side.value("peak_elevation_error_deg"))
    assert row["sim_mean"] == pytest.approx(row["real_mean"]) and row["real_sd"] == pytest.approx(0.0, abs=1e-12)
    assert row["agrees"] is True and np.isnan(row["agree_chance"])  # one subject: no spread between people
    unsimulated = summary["movements"]["m10"]["elevation_trace_rmse_deg"]
    assert unsimulated["sim_n"] == 0 and np.isnan(unsimulated["sim_mean"]) and unsimulated["agrees"] is None
    assert [e["episode"] for e in summary["episodes"]] == ["m07_s01_e01", "m07_s01_e02", "m10_s01_e01"]
    assert summary["episodes"][2]["problem"] == "not simulated" and summary["episodes"][0]["side"] == "right"
    assert len(summary["episodes"][0]["sims"]) == 2 and set(summary["episodes"][0]["real"]) == set(STATISTICS)
    # one real subject: no interval over people; its two seeds are two simulated people of equal errors
    assert np.isnan(row["real_interval"]).all()
    assert row["sim_interval"] == pytest.approx([row["sim_mean"]] * 2)


def test_people_interval_counts_each_person_once():
    one_each = people_interval([("a", 1.0), ("b", 3.0), ("c", 5.0)])
    t = 4.302652729911275  # t(0.975, 2 df)
    assert one_each == pytest.approx([3.0 - t * 2.0 / np.sqrt(3), 3.0 + t * 2.0 / np.sqrt(3)])
    # a person with many episodes weighs as one; NaN values are left out
    many = people_interval([("a", 1.0)] * 50 + [("b", 3.0), ("b", np.nan), ("c", 4.0), ("c", 6.0)])
    assert many == pytest.approx(one_each)
    assert np.isnan(people_interval([("a", 1.0), ("a", 2.0)])).all()


def test_agree_chance_from_the_per_person_differences():
    from scipy import stats

    # differences real - simulated per person 2, 4, 6 (sd 2, se 2 / sqrt 3); tolerance 3 deg at real mean 1
    real = [("a", 3.0), ("a", 5.0), ("b", 5.0), ("c", 7.0)]  # a's mean 4
    sim = [("a", 2.0), ("b", 1.0), ("b", 1.0), ("c", 1.0), ("d", 9.0)]  # d has no real values: left out
    chance = agree_chance("peak_elevation_error_deg", 1.0, real, sim)
    assert chance == pytest.approx(2 * stats.t.cdf(3.0 / (2.0 / np.sqrt(3)), 2) - 1)
    # the trace RMSE's tolerance is 30 % of the real mean alone; a wider spread lowers the chance
    assert agree_chance("elevation_trace_rmse_deg", 1.0, real, sim) < chance
    assert agree_chance("peak_elevation_error_deg", 1.0, [("a", 0.0), ("b", 10.0), ("c", -10.0)],
                        [("a", 0.0), ("b", 0.0), ("c", 0.0)]) < chance
    # every person differing alike: certain; fewer than three people: unknown
    assert agree_chance("peak_elevation_error_deg", 1.0, [("a", 5.0), ("b", 5.0), ("c", 5.0)],
                        [("a", 1.0), ("b", 1.0), ("c", 1.0)]) == 1.0
    assert np.isnan(agree_chance("peak_elevation_error_deg", 1.0, real[:3], sim))


# --------------------------------------------------------------------------------------------------
# fit_arm_bias

RNG = np.random.default_rng(11)
PEOPLE = {p: RNG.uniform(-0.04, 0.04, (3, 5, 3)) for p in ("s01", "s02", "s03")}  # knots, forearm terms
TRUNKS = {p: RNG.uniform(-0.12, 0.04, (3, 3, 3)) for p in PEOPLE}


def _basis(elevation_deg: np.ndarray) -> np.ndarray:
    e = elevation_deg / 90.0
    return np.column_stack([np.ones_like(e), e, e ** 2])


def _arm_basis(elevation_deg: np.ndarray) -> np.ndarray:
    """The knots' weights and a forearm turning forward and outward as the arm rises."""
    e = np.radians(elevation_deg)
    return np.column_stack([_basis(elevation_deg), 0.5 * np.sin(3 * e), 0.4 * np.cos(5 * e) ** 2])


def _episode(subject: str, elevation_deg: np.ndarray, coefficients: np.ndarray) -> EpisodeOffsets:
    """Arm offsets of ``coefficients`` at the elevations, trunk offsets of the subject's :data:`TRUNKS`
    at a higher arm's elevation 20 deg above them."""
    basis, higher = _arm_basis(elevation_deg), _basis(elevation_deg + 20.0)
    return EpisodeOffsets(subject, basis, np.einsum("tp,jpa->tja", basis, coefficients),
                          higher, np.einsum("tp,jpa->tja", higher, TRUNKS[subject]))


def _offsets() -> list[EpisodeOffsets]:
    out = []
    for k, (p, c) in enumerate(PEOPLE.items()):
        out.append(_episode(p, np.linspace(5.0, 150.0, 40 + k), c))
        out.append(_episode(p, np.linspace(0.0, 120.0, 25), c))
    return out


def _assert_modes_give_the_covariance(modes: np.ndarray, people: np.ndarray) -> None:
    """The modes (K, 3, P, 3) of ``people`` (n, 3, P, 3): sum_k mode_k mode_k^T is their sample covariance."""
    n = len(people)
    assert modes.ndim == 4 and modes.shape[1:] == people.shape[1:] and modes.shape[0] <= n - 1
    flat = modes.reshape(len(modes), -1)
    np.testing.assert_allclose(flat.T @ flat, np.cov(people.reshape(n, -1), rowvar=False, ddof=1), atol=1e-12)


def test_person_modes_are_scaled_orthogonal_principal_components():
    rng = np.random.default_rng(4)
    people = rng.uniform(-0.03, 0.03, (5, 3, 3, 3))
    modes = person_modes(people)
    assert modes.shape == (4, 3, 3, 3)  # n - 1 modes: the deviations from the mean sum to zero
    _assert_modes_give_the_covariance(modes, people)
    flat = modes.reshape(4, -1)
    gram = flat @ flat.T
    np.testing.assert_allclose(gram, np.diag(np.diag(gram)), atol=1e-12)  # orthogonal
    assert np.all(np.diff(np.diag(gram)) <= 0)  # largest first
    # people who differ along one direction only have one mode; identical people have none
    direction = rng.uniform(-0.01, 0.01, (3, 3, 3))
    line = people[0] + np.array([-1.0, 0.0, 0.5, 2.0])[:, None, None, None] * direction
    one = person_modes(line)
    assert one.shape == (1, 3, 3, 3)
    _assert_modes_give_the_covariance(one, line)
    assert person_modes(np.stack([people[0]] * 2)).shape == (0, 3, 3, 3)  # (their mean is exact)
    assert person_modes(np.zeros((3, 3, 3, 3))).shape == (0, 3, 3, 3)


def test_fit_recovers_known_coefficients_and_their_spread():
    fit = fit_arm_bias(_offsets())
    assert sorted(fit.per_person) == sorted(PEOPLE)
    for p, c in PEOPLE.items():
        np.testing.assert_allclose(fit.per_person[p], c, atol=1e-10)
    stack = np.stack(list(PEOPLE.values()))
    np.testing.assert_allclose(np.asarray(fit.arm_bias.mean_m), stack.mean(axis=0), atol=1e-10)
    _assert_modes_give_the_covariance(np.asarray(fit.arm_bias.person_modes_m), stack)
    assert dict(fit.episodes) == {"s01": 2, "s02": 2, "s03": 2}
    for p, c in TRUNKS.items():
        np.testing.assert_allclose(fit.per_person_trunk[p], c, atol=1e-10)
    trunks = np.stack(list(TRUNKS.values()))
    np.testing.assert_allclose(np.asarray(fit.trunk_bias.mean_m), trunks.mean(axis=0), atol=1e-10)
    _assert_modes_give_the_covariance(np.asarray(fit.trunk_bias.person_modes_m), trunks)


def test_fit_excludes_a_person():
    fit = fit_arm_bias(_offsets(), exclude="s02")
    assert sorted(fit.per_person) == ["s01", "s03"] and "s02" not in fit.episodes
    two = np.stack([PEOPLE["s01"], PEOPLE["s03"]])
    np.testing.assert_allclose(np.asarray(fit.arm_bias.mean_m), two.mean(axis=0), atol=1e-10)
    modes = np.asarray(fit.arm_bias.person_modes_m)
    assert modes.shape == (1, 3, 5, 3)
    _assert_modes_give_the_covariance(modes, two)
    # two people: the one mode is half their difference times sqrt(2), up to sign
    half = (two[0] - two[1]) / np.sqrt(2)
    assert min(np.abs(modes[0] - half).max(), np.abs(modes[0] + half).max()) < 1e-10


def test_fit_needs_two_people():
    one = [o for o in _offsets() if o.subject == "s01"]
    with pytest.raises(BadInputError, match="two people"):
        fit_arm_bias(one)
    with pytest.raises(BadInputError, match="two people"):
        fit_arm_bias([o for o in _offsets() if o.subject != "s03"], exclude="s01")
    with pytest.raises(BadInputError, match="two people"):
        fit_arm_bias([])


def test_gross_and_missing_frames_are_left_out(monkeypatch):
    c = PEOPLE["s01"]
    good = _episode("s01", np.linspace(0.0, 140.0, 30), c)
    elevation = np.linspace(10.0, 130.0, 12)
    bad = _episode("s01", elevation, c)
    offsets = bad.offsets.copy()
    offsets[::2, 0] = [0.0, GROSS_M + 0.01, 0.0]  # tracking failures of the shoulder, just beyond GROSS_M
    offsets[1::4, 2] = [0.0, 0.0, -2 * GROSS_M]  # and of the wrist
    offsets[3, 1] = np.nan  # a missing elbow
    noisy = EpisodeOffsets("s01", bad.basis, offsets, bad.trunk_basis, bad.trunk_offsets)
    np.testing.assert_allclose(person_coefficients([good, noisy]), c, atol=1e-10)
    # the gross frames would pull the fit away if they counted
    monkeypatch.setattr("scenarios.sensors.fit_arm_bias.GROSS_M", 10.0)
    counted = person_coefficients([good, noisy])
    assert np.abs(counted[0] - c[0]).max() > 0.01 and np.abs(counted[2] - c[2]).max() > 0.01


def test_person_coefficients_needs_enough_frames():
    few = _episode("s01", np.linspace(0.0, 90.0, 8), PEOPLE["s01"])
    with pytest.raises(BadInputError, match="too few frames"):
        person_coefficients([few])


def test_with_arm_bias_adds_the_fit_and_its_provenance():
    fit = fit_arm_bias(_offsets())
    profile = with_arm_bias(load_profile("kinect_v2"), fit, "UI-PRMD test")
    assert profile.tracker.arm_bias == fit.arm_bias and profile.tracker.trunk_bias == fit.trunk_bias
    for key in ("tracker.arm_bias.mean_m", "tracker.arm_bias.person_modes_m", "tracker.trunk_bias.mean_m",
                "tracker.trunk_bias.person_modes_m"):
        assert "UI-PRMD test" in profile.provenance[key] and "s02 (2 episodes)" in profile.provenance[key]
    assert profile_from_dict(tomllib.loads(profile_to_toml(profile))) == profile


def test_with_arm_bias_of_one_part_keeps_the_other_as_the_profile_has_it():
    fit, base = fit_arm_bias(_offsets()), load_profile("kinect_v2")
    trunk = with_arm_bias(base, fit, "UI-PRMD test", parts=("trunk",))
    assert trunk.tracker.trunk_bias == fit.trunk_bias and trunk.tracker.arm_bias == base.tracker.arm_bias
    assert trunk.provenance["tracker.arm_bias.mean_m"] == base.provenance["tracker.arm_bias.mean_m"]
    arm = with_arm_bias(base, fit, "UI-PRMD test", parts=("arm",))
    assert arm.tracker.arm_bias == fit.arm_bias and arm.tracker.trunk_bias is None
    assert not any(k.startswith("tracker.trunk_bias") for k in arm.provenance)


def test_the_command_refuses_a_folder_that_is_not_ui_prmd_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["angle-validate", str(tmp_path), "--out", str(out), "--jobs", "1"]) == 2
    assert "Segmented Movements" in capsys.readouterr().err
    assert not out.exists() or not any(out.iterdir())


def test_the_command_refuses_leave_one_out_without_fit(tmp_path, dataset, capsys):
    assert main(["angle-validate", str(dataset), "--leave-one-out", "--out", str(tmp_path / "o"), "--jobs", "1"]) == 2
    assert "--fit" in capsys.readouterr().err


def test_the_command_refuses_an_unknown_part_to_fit(tmp_path, dataset, capsys):
    with pytest.raises(SystemExit):
        main(["angle-validate", str(dataset), "--fit", "elbow", "--out", str(tmp_path / "o"), "--jobs", "1"])
    assert "invalid choice: 'elbow'" in capsys.readouterr().err
    with pytest.raises(BadInputError, match="can fit the parts arm, trunk"):
        validate_dataset(dataset, tmp_path / "o", command="test", fit=["elbow"])
