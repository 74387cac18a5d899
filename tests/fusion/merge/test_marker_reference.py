"""Joint centres from Plug-in-Gait markers: synthetic arms rotating about known centres, the fallback,
missing markers, the chord rule, the skeleton stream, and plausible facts on UI-PRMD."""

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from scipy.spatial.transform import Rotation

from fusion.errors import BadInputError, UnknownNameError
from fusion.io.mocap_files import MarkerData
from fusion.merge.angles import joint_angles
from fusion.merge.centre_fit import fit_common_centre
from fusion.merge.marker_reference import (
    REFERENCE_JOINTS,
    CentreMethod,
    GhAnchor,
    ReferenceOptions,
    chord_centre,
    isb_thorax_frame,
    marker_reference,
    reference_skeleton,
)
from fusion.topology import KINECT_V2, TrackingState
from fusion.transforms import apply, make_transform
from tests.strategies import seeds

SAMPLES = Path(__file__).resolve().parents[3].parent / "shared" / "samples" / "ui_prmd"

# Body frame: x forward, y left, z up; its ISB thorax axes are X = x, Y = z, Z = -y.
THORAX = {"CLAV": (0.08, 0.0, 1.45), "C7": (-0.08, 0.0, 1.52), "STRN": (0.10, 0.0, 1.28), "T10": (-0.10, 0.0, 1.25)}
C_THORAX = np.array([0.01, -0.05, 0.005])  # GH centre relative to xSHO in thorax axes [m]
C_BODY = np.array([C_THORAX[0], -C_THORAX[2], C_THORAX[1]])
RADIUS = 0.5 * (0.067 + 0.014)


def _arm_rotations(n: int, elevation_deg: float, plane_deg: tuple[float, float], axial_deg: float) -> np.ndarray:
    """(n, 3, 3) humerus orientations in the body frame of a right arm: elevation up to
    ``elevation_deg`` in a plane sweeping ``plane_deg`` (0 frontal, 90 forward), axial rotation."""
    s = np.linspace(0.0, 1.0, n)
    elev = elevation_deg * np.sin(np.pi * s)
    plane = plane_deg[0] + (plane_deg[1] - plane_deg[0]) * s
    axial = axial_deg * np.sin(2 * np.pi * s)
    # Elevation raises the arm from hanging (-z) toward the direction (cos p) right + (sin p) forward.
    return Rotation.from_euler("ZXZ", np.stack([plane, -elev, axial], axis=1) * [1, 1, 1], degrees=True).as_matrix()


def _synthetic(n: int = 120, elevation_deg: float = 120.0, plane_deg=(-20.0, 70.0), axial_deg: float = 30.0,
               T_world_body: np.ndarray | None = None, noise_m: float = 0.0, seed: int = 0,
               flex_deg: float = 0.0) -> tuple[MarkerData, np.ndarray, np.ndarray]:
    """Markers of a body whose right humerus rotates about a known GH centre (left arm still), and the
    true right GH and elbow centres (n, 3) in the world."""
    rng = np.random.default_rng(seed)
    T = np.eye(4) if T_world_body is None else T_world_body
    R_arm = _arm_rotations(n, elevation_deg, plane_deg, axial_deg)
    m = {k: np.tile(v, (n, 1)) for k, v in THORAX.items()}
    for s, y in (("L", 1.0), ("R", -1.0)):
        sho = np.array([0.0, 0.19 * y, 1.47])
        m[f"{s}SHO"] = np.tile(sho, (n, 1))
        m[f"{s}ASI"] = np.tile([0.12, 0.12 * y, 1.0], (n, 1))
        m[f"{s}PSI"] = np.tile([-0.12, 0.05 * y, 1.05], (n, 1))  # pelvis centred under the spine
        gh = sho + C_BODY * [1, -y, 1] if s == "R" else sho + [C_BODY[0], C_BODY[1], C_BODY[2]]
        # Humerus-fixed points of a hanging arm, relative to GH: the epicondyle lateral (away from the body).
        local = {"UPA": [0.0, 0.045 * y, -0.15], "EJC": [0.0, 0.0, -0.30], "ELB": [0.0, RADIUS * y, -0.30],
                 "WJC": [0.0, 0.0, -0.56], "WRA": [0.0, 0.025 * y, -0.56], "WRB": [0.0, -0.025 * y, -0.56]}
        R = R_arm if s == "R" else np.tile(np.eye(3), (n, 1, 1))
        flex = Rotation.from_rotvec(np.outer(-np.radians(flex_deg) * np.sin(np.linspace(0.0, np.pi, n)) ** 2,
                                             [0.0, 1.0, 0.0]))
        for k in ("WJC", "WRA", "WRB"):  # the forearm bends forward about the lateral axis through EJC
            local[k] = np.array(local["EJC"]) + flex.apply(np.array(local[k]) - local["EJC"])
        pts = {k: gh + np.einsum("tij,t...j->ti", R, np.broadcast_to(v, (n, 3))) for k, v in local.items()}
        if noise_m:
            for k in ("UPA", "ELB"):
                pts[k] = pts[k] + rng.normal(0.0, noise_m, pts[k].shape)
        for k in ("UPA", "ELB", "WRA", "WRB"):
            m[f"{s}{k}"] = pts[k]
        if s == "R":
            gh_true, ejc_true = np.tile(gh, (n, 1)), pts["EJC"]
    names = tuple(m)
    P = np.stack([apply(T, m[k]) for k in names], axis=1)
    return MarkerData(names, np.arange(n) / 100.0, P, "synthetic"), apply(T, gh_true), apply(T, ejc_true)


POSE = make_transform(Rotation.from_euler("z", 40, degrees=True).as_matrix(), np.array([1.0, -2.0, 0.05]))


def test_fit_common_centre_exact_and_bad_input():
    c = np.array([0.1, -0.2, 0.3])
    d = Rotation.from_rotvec(np.random.default_rng(1).normal(0, 0.8, (50, 3))).apply([0.0, 0.0, -0.3])
    fit = fit_common_centre(np.stack([c + d, c + 0.5 * d], axis=1))
    assert np.allclose(fit.centre, c, atol=1e-9) and fit.n_determined == 3 and fit.residual_rms_m < 1e-9
    assert fit.spreads_m.shape == (3,) and np.all(np.diff(fit.spreads_m) <= 0)
    with pytest.raises(BadInputError):
        fit_common_centre(np.zeros((5, 3)))
    with pytest.raises(BadInputError):
        fit_common_centre(np.zeros((5, 2, 3)), prior=np.array([np.nan, 0, 0]))


def test_isb_thorax_frame_of_upright_body():
    R = isb_thorax_frame(*(np.array(THORAX[k]) for k in ("C7", "CLAV", "T10", "STRN")))
    assert np.allclose(R, [[1, 0, 0], [0, 0, -1], [0, 1, 0]], atol=1e-12)


@pytest.mark.parametrize("T_world_body", [np.eye(4), POSE])
def test_functional_gh_centre_within_a_millimetre(T_world_body):
    data, gh, _ = _synthetic(T_world_body=T_world_body)
    ref = marker_reference(data)
    assert ref.method("gh_right") is CentreMethod.FUNCTIONAL
    assert np.max(np.linalg.norm(ref["gh_right"] - gh, axis=1)) < 1e-3
    assert ref.fits["right"].residual_rms_m < 1e-6
    assert ref.positions.shape == (len(data.times), len(REFERENCE_JOINTS), 3)


@settings(max_examples=8)
@given(seed=seeds)
def test_functional_gh_centre_error_scales_with_noise(seed):
    for noise in (0.001, 0.004):
        data, gh, _ = _synthetic(noise_m=noise, seed=seed)
        ref = marker_reference(data)
        err = np.max(np.linalg.norm(ref["gh_right"] - gh, axis=1))
        assert err < 3.0 * noise, (noise, err)
        assert 0.3 * noise < ref.fits["right"].residual_rms_m < 1.5 * noise


def test_still_arm_falls_back_to_the_acromion_regression():
    data, _, _ = _synthetic(T_world_body=POSE)
    ref = marker_reference(data)
    assert ref.method("gh_left") is CentreMethod.REGRESSION and ref.fits["left"].n_determined == 0
    sho = data.positions[:, data.names.index("LSHO")]
    width = np.linalg.norm(sho - data.positions[:, data.names.index("RSHO")], axis=1)
    expected = sho - 0.17 * width[:, None] * ref.R_world_thorax[:, :, 1]
    assert np.allclose(ref["gh_left"], expected, atol=1e-9)


def test_planar_arc_determines_the_centre_in_its_plane_only():
    data, gh, _ = _synthetic(plane_deg=(0.0, 0.0), axial_deg=0.0, elevation_deg=90.0)
    ref = marker_reference(data)
    fit = ref.fits["right"]
    assert ref.method("gh_right") is CentreMethod.FUNCTIONAL_PARTIAL and fit.n_determined == 2
    axis = fit.directions[:, 2]  # the undetermined direction: the rotation axis (thorax X)
    assert abs(abs(axis[0]) - 1.0) < 1e-6
    err = ref["gh_right"] - gh
    R = ref.R_world_thorax
    err_thorax = np.einsum("tki,tk->ti", R, err)
    assert np.max(np.abs(err_thorax[:, 1:])) < 1e-6  # in the plane: exact
    assert np.allclose(err_thorax[:, 0], -C_THORAX[0], atol=1e-6)  # along the axis: the regression's 0


def test_thorax_anchor_gives_the_same_centre_for_a_fixed_girdle():
    data, gh, _ = _synthetic()
    ref = marker_reference(data, ReferenceOptions(anchor=GhAnchor.THORAX))
    assert np.max(np.linalg.norm(ref["gh_right"] - gh, axis=1)) < 1e-3


def test_missing_markers_give_nan_not_garbage():
    data, gh, _ = _synthetic()
    P = np.array(data.positions)
    P[10:20, data.names.index("RELB")] = np.nan
    P[30:40, data.names.index("RWRB")] = np.nan
    ref = marker_reference(MarkerData(data.names, data.times, P))
    assert np.isnan(ref["elbow_right"][10:20]).all() and np.isnan(ref["wrist_right"][30:40]).all()
    assert np.isfinite(ref["elbow_right"][30:40]).all()  # carried by the humerus markers, not the wrist
    assert np.isfinite(ref["gh_right"]).all() and np.max(np.linalg.norm(ref["gh_right"] - gh, axis=1)) < 1e-3
    P[:, data.names.index("STRN")] = np.nan
    ref = marker_reference(MarkerData(data.names, data.times, P))
    assert np.isnan(ref.R_world_thorax).all() and np.isnan(ref["gh_right"]).all()
    assert ref.method("gh_right") is CentreMethod.MISSING and ref.method("thorax_lower") is CentreMethod.MISSING
    with pytest.raises(UnknownNameError):
        marker_reference(MarkerData(data.names[1:], data.times, P[:, 1:]))


def test_chord_rule_finds_the_elbow_of_a_straight_arm_and_leans_to_the_wrist_of_a_bent_one():
    gh, ejc = np.array([0.0, 0.0, 0.3]), np.zeros(3)
    elb = np.array([0.0, -RADIUS, 0.0])  # lateral of a right arm
    assert np.allclose(chord_centre(gh, elb, np.array([0.0, 0.0, -0.26]), RADIUS), ejc, atol=1e-12)
    bent = chord_centre(gh, elb, np.array([0.25, 0.0, 0.0]), RADIUS)  # 90 deg flexion: off, as documented
    assert 0.04 < np.linalg.norm(bent - ejc) < 0.06 and bent[0] > 0.03
    assert np.isnan(chord_centre(gh, elb, np.array([np.nan, 0, 0]), RADIUS)).all()


def test_elbow_centre_of_the_synthetic_arm():
    data, _, ejc = _synthetic(T_world_body=POSE)
    ref = marker_reference(data)
    assert ref.method("elbow_right") is CentreMethod.CHORD_OFFSET
    assert np.max(np.linalg.norm(ref["elbow_right"] - ejc, axis=1)) < 1e-3


def test_elbow_centre_follows_a_bending_elbow():
    data, _, ejc = _synthetic(T_world_body=POSE, flex_deg=70.0)
    ref = marker_reference(data)
    assert ref.elbow_calibration_deg["right"] < 2.0
    assert np.max(np.linalg.norm(ref["elbow_right"] - ejc, axis=1)) < 2e-3
    angles = joint_angles(reference_skeleton(ref).positions, KINECT_V2)
    expected = 70.0 * np.sin(np.linspace(0.0, np.pi, len(data.times))) ** 2
    assert np.max(np.abs(angles["elbow_flexion_right"] - expected)) < 1.0


def test_reference_skeleton_feeds_the_kinect_angle_code():
    data, _, _ = _synthetic(T_world_body=POSE)
    stream = reference_skeleton(marker_reference(data))
    assert stream.topology is KINECT_V2 and stream.positions.shape == (len(data.times), 25, 3)
    filled = {"SpineBase", "SpineShoulder", "SpineMid", "ShoulderLeft", "ShoulderRight", "ElbowLeft", "ElbowRight",
              "WristLeft", "WristRight", "HipLeft", "HipRight"}
    hips = stream.positions[:, [KINECT_V2.index("HipLeft"), KINECT_V2.index("HipRight")]].mean(axis=1)
    np.testing.assert_allclose(stream.positions[:, KINECT_V2.index("SpineBase")], hips)
    for j, name in enumerate(KINECT_V2.joints):
        if name in filled:
            assert (stream.states[:, j] == TrackingState.TRACKED).all()
        else:
            assert np.isnan(stream.positions[:, j]).all() and (stream.states[:, j] == 0).all()
    angles = joint_angles(stream.positions, stream.topology)
    s = np.linspace(0.0, 1.0, len(data.times))
    assert np.allclose(angles["ht_elevation_right"], 120.0 * np.sin(np.pi * s), atol=1e-6)
    assert np.allclose(angles["elbow_flexion_right"], 0.0, atol=1e-4)
    plane = angles["ht_plane_of_elevation_right"]
    defined = np.isfinite(plane)
    offset = plane[defined] - np.linspace(-20.0, 70.0, len(s))[defined]
    # The project's thorax Z is the glenohumeral line, here turned about Y by the right centre's 1 cm
    # forward offset (the left one is the regression's, straight below xSHO): a constant offset.
    assert defined.sum() > 50 and np.ptp(offset) < 1e-6
    assert np.isclose(offset[0], -np.degrees(np.arctan2(C_THORAX[0], 0.38 + C_THORAX[2])), atol=1e-6)


EPISODES = [f"m07_s01_e{e:02d}" for e in (1, 2, 3)]


@pytest.mark.skipif(not SAMPLES.is_dir(), reason="UI-PRMD samples not present")
@pytest.mark.parametrize("episode", EPISODES)
def test_ui_prmd_reference_is_plausible(episode):
    from fusion.io.formats.ui_prmd import read_ui_prmd_vicon

    data = read_ui_prmd_vicon(SAMPLES / "Segmented Movements" / "Vicon" / "Positions" / f"{episode}_positions.txt.gz")
    ref = marker_reference(data)
    for side, s in (("left", "L"), ("right", "R")):
        below = np.einsum("ti,ti->t", data.positions[:, data.names.index(f"{s}SHO")] - ref[f"gh_{side}"],
                          ref.R_world_thorax[:, :, 1])
        assert 0.03 <= np.nanmedian(below) <= 0.08, (side, np.nanmedian(below))
    angles = joint_angles(reference_skeleton(ref).positions, KINECT_V2)
    assert np.nanmax(angles["ht_elevation_right"]) > 120.0  # an abduction of the right arm
    assert np.nanmax(angles["elbow_flexion_right"]) < 25.0
