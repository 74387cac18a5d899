"""UI-PRMD readers: the forward kinematics against oracles, the axis map, round trips of fixture files
written here, the zero-marker rule, every kind of bad file, the 22-joint topology, the Plug-in-Gait
map, and (when the samples are present) plausible facts of a real Kinect and Vicon episode."""

from __future__ import annotations

import gzip
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from fusion.camera import KINECT_V2_DEPTH, AxisConvention, Intrinsics
from fusion.errors import BadInputError, RecordingError, UnknownNameError
from fusion.io.formats import read_ui_prmd_kinect, read_ui_prmd_vicon
from fusion.io.formats.ui_prmd import (
    KINECT_CAMERA,
    R_CAM_FILE,
    VICON_MARKERS,
    angles_file_for,
    episode_info,
    euler_zxy,
    forward_kinematics,
    join_episodes,
)
from fusion.io.marker_map import apply_marker_map, load_marker_map
from fusion.skeleton import SkeletonStream
from fusion.topology import (
    KINECT_V2,
    UI_PRMD,
    Landmark,
    Topology,
    TrackingState,
    topology_by_name,
)
from tests.fusion.io.ui_prmd_files import episode_rows, write_rows

SAMPLES = Path(__file__).resolve().parents[3].parent / "shared" / "samples" / "ui_prmd"
README_PARENTS = (-1, 0, 1, 2, 3, 4, 2, 6, 7, 8, 2, 10, 11, 12, 0, 14, 15, 16, 0, 18, 19, 20)

# --------------------------------------------------------------------------------------------------
# Fixture files


def _kinect_files(root: Path, name: str = "m07_s02_e03", suffix: str = "", n_frames: int = 12,
                  ) -> tuple[Path, Path, np.ndarray, np.ndarray]:
    """An episode in the data set's layout: ``Kinect/Positions`` and ``Kinect/Angles``."""
    p, a = episode_rows(n_frames)
    pos = write_rows(root / "Kinect" / "Positions" / f"{name}_positions{suffix}.txt.gz", p)
    ang = write_rows(root / "Kinect" / "Angles" / f"{name}_angles{suffix}.txt.gz", a)
    return pos, ang, p, a


def _vicon_rows(n_frames: int = 5) -> np.ndarray:
    """(T, 117) markers [mm]: each marker at a distinct place, moving 1 mm per frame along x."""
    base = np.stack([np.arange(39) * 10.0 + 100.0, np.arange(39) * -5.0 + 50.0, np.linspace(1600, 50, 39)], axis=1)
    return (base[None] + np.arange(n_frames)[:, None, None] * np.array([1.0, 0.0, 0.0])).reshape(n_frames, -1)


# --------------------------------------------------------------------------------------------------
# Rotations and forward kinematics against oracles

angle = st.floats(-360.0, 360.0, allow_nan=False)


@given(alpha=angle, beta=angle, gamma=angle)
def test_euler_zxy_is_scipys_intrinsic_zxy(alpha, beta, gamma):
    expected = Rotation.from_euler("ZXY", [gamma, alpha, beta], degrees=True).as_matrix()
    np.testing.assert_allclose(euler_zxy(np.array([alpha, beta, gamma])), expected, atol=1e-12)


def test_euler_zxy_order_and_single_axes():
    # one axis at a time: about x takes y to z, about y takes z to x, about z takes x to y
    np.testing.assert_allclose(euler_zxy([90, 0, 0]) @ [0, 1, 0], [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(euler_zxy([0, 90, 0]) @ [0, 0, 1], [1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(euler_zxy([0, 0, 90]) @ [1, 0, 0], [0, 1, 0], atol=1e-12)
    # the order shows with several angles: Ry(30) first, then Rx(60), then Rz(90) (applied to a vector)
    R = euler_zxy([60, 30, 90])
    Rz, Rx, Ry = (Rotation.from_euler(a, d, degrees=True).as_matrix() for a, d in (("z", 90), ("x", 60), ("y", 30)))
    np.testing.assert_allclose(R, Rz @ Rx @ Ry, atol=1e-12)
    for other in (Rx @ Ry @ Rz, Ry @ Rx @ Rz, Rz @ Ry @ Rx, Rx @ Rz @ Ry, Ry @ Rz @ Rx):
        assert not np.allclose(R, other)
    assert euler_zxy(np.zeros((4, 7, 3))).shape == (4, 7, 3, 3)


def test_forward_kinematics_of_a_chain_with_known_rotations():
    # root at (1, 2, 3) turned 90 deg about z; child 1 10 up in the root's frame, turned 90 deg about x;
    # child 2 5 along x in child 1's frame; child 3 a sibling of child 2, 4 along z
    offsets = np.array([[[1, 2, 3], [0, 10, 0], [5, 0, 0], [0, 0, 4]]], dtype=float)
    angles = np.array([[[0, 0, 90], [90, 0, 0], [0, 0, 0], [0, 0, 0]]], dtype=float)
    X = forward_kinematics(offsets, angles, (-1, 0, 1, 1))
    # G0 = Rz90: (0,10,0) -> (-10,0,0); G1 = Rz90 Rx90: (5,0,0) -> (0,5,0), (0,0,4) -> Rz90 (0,-4,0) = (4,0,0)
    np.testing.assert_allclose(X[0], [[1, 2, 3], [-9, 2, 3], [-9, 7, 3], [-5, 2, 3]], atol=1e-12)


def test_forward_kinematics_matches_a_scipy_oracle_on_the_ui_prmd_tree():
    rng = np.random.default_rng(4)
    offsets = rng.normal(0, 20, (6, 22, 3))
    angles = rng.uniform(-180, 180, (6, 22, 3))
    X = forward_kinematics(offsets, angles, UI_PRMD.parents)
    for t in range(6):
        G, P = [], []
        for j, parent in enumerate(UI_PRMD.parents):
            R = Rotation.from_euler("ZXY", angles[t, j, [2, 0, 1]], degrees=True)
            if parent < 0:
                G.append(R)
                P.append(offsets[t, j])
            else:
                G.append(G[parent] * R)
                P.append(P[parent] + G[parent].apply(offsets[t, j]))
        np.testing.assert_allclose(X[t], np.array(P), atol=1e-9)
    bones = UI_PRMD.bones
    np.testing.assert_allclose(np.linalg.norm(X[:, bones[:, 1]] - X[:, bones[:, 0]], axis=-1),
                               np.linalg.norm(offsets[:, bones[:, 1]], axis=-1), rtol=1e-12)


def test_forward_kinematics_bad_input():
    with pytest.raises(BadInputError, match="offsets and angles"):
        forward_kinematics(np.zeros((2, 3, 3)), np.zeros((2, 4, 3)), (-1, 0, 1))
    with pytest.raises(BadInputError, match="parents"):
        forward_kinematics(np.zeros((2, 3, 3)), np.zeros((2, 3, 3)), (-1, 2, 0))


# --------------------------------------------------------------------------------------------------
# Topology


def test_ui_prmd_topology_is_a_registered_value():
    assert topology_by_name("ui_prmd") is UI_PRMD and UI_PRMD.n_joints == 22
    assert UI_PRMD.parents == README_PARENTS
    assert len(UI_PRMD.bones) == 21 and len(UI_PRMD.lr_pairs) == 8
    assert UI_PRMD.joints[UI_PRMD.mirror[UI_PRMD.index("ForearmLeft")]] == "ForearmRight"
    assert UI_PRMD.index(Landmark.SHOULDER_LEFT) == UI_PRMD.index("UpperArmLeft")
    assert UI_PRMD.index(Landmark.WRIST_RIGHT) == UI_PRMD.index("HandRight")
    assert UI_PRMD.index(Landmark.FOOT_LEFT) == UI_PRMD.index("ToesLeft")
    assert UI_PRMD.index(Landmark.HEAD) == UI_PRMD.index("HeadTip")


@pytest.mark.parametrize("lm", [Landmark.HAND_LEFT, Landmark.HANDTIP_RIGHT, Landmark.THUMB_LEFT])
def test_a_landmark_the_joint_set_lacks_is_an_error_not_a_stand_in(lm):
    with pytest.raises(UnknownNameError, match=lm.value):
        UI_PRMD.index(lm)


def test_a_topology_must_map_or_declare_every_landmark():
    spec = dict(name="x", joints=KINECT_V2.joints, parents=KINECT_V2.parents, regions=KINECT_V2.regions)
    partial = {lm: j for lm, j in KINECT_V2.landmarks.items() if lm is not Landmark.THUMB_LEFT}
    with pytest.raises(BadInputError, match="thumb_left"):
        Topology(**spec, landmarks=partial)
    assert Topology(**spec, landmarks=partial, lacks=frozenset({Landmark.THUMB_LEFT})).n_joints == 25
    with pytest.raises(BadInputError, match="both"):
        Topology(**spec, landmarks=KINECT_V2.landmarks, lacks=frozenset({Landmark.THUMB_LEFT}))


def test_ui_prmd_is_a_kinect_v2_set_reduced_to_the_joints_it_names():
    """Each joint is the Kinect v2 joint of its landmark; the stand-ins near the base of the neck (the
    file's Neck and collars) are the Kinect v2's spine-shoulder, their nearest ancestor's joint."""
    assert UI_PRMD.full_set is KINECT_V2 and KINECT_V2.full_set is KINECT_V2
    cols = UI_PRMD.columns_in(KINECT_V2)
    named = dict(zip(UI_PRMD.joints, (KINECT_V2.joints[c] for c in cols)))
    assert named["UpperArmLeft"] == "ShoulderLeft" and named["HandRight"] == "WristRight"
    assert named["HeadTip"] == "Head" and named["Head"] == "Neck" and named["ToesLeft"] == "FootLeft"
    assert named["Neck"] == named["CollarLeft"] == named["CollarRight"] == named["Chest"] == "SpineShoulder"
    np.testing.assert_array_equal(KINECT_V2.columns_in(KINECT_V2), np.arange(25))
    with pytest.raises(BadInputError, match="does not cover the kinect_v2 joint set: it has no joint for hand_left"):
        KINECT_V2.columns_in(UI_PRMD)
    T = 3
    full = SkeletonStream(KINECT_V2, np.arange(T) / 30, np.random.default_rng(0).normal(size=(T, 25, 3)),
                          np.tile(np.arange(25) % 3, (T, 1)))
    reduced = full.as_joint_set(UI_PRMD)
    assert reduced.topology is UI_PRMD
    np.testing.assert_array_equal(reduced.positions, full.positions[:, cols])
    np.testing.assert_array_equal(reduced.states, full.states[:, cols])


# --------------------------------------------------------------------------------------------------
# Kinect reader


def test_kinect_round_trip_of_a_fixture_episode(tmp_path):
    pos, ang, p, a = _kinect_files(tmp_path)
    rec = read_ui_prmd_kinect(pos)
    (cam,) = rec.cameras
    s = cam.skeleton
    assert cam.name == KINECT_CAMERA and cam.intrinsics == KINECT_V2_DEPTH
    assert cam.intrinsics.axes is AxisConvention.KINECT_V2 and s.topology is UI_PRMD
    X_file = forward_kinematics(p.reshape(-1, 22, 3), a.reshape(-1, 22, 3), README_PARENTS)
    np.testing.assert_allclose(s.positions, X_file @ R_CAM_FILE.T / 100.0, atol=1e-12)
    np.testing.assert_allclose(s.timestamps, np.arange(12) / 30.0)
    assert np.all(s.states == TrackingState.TRACKED)
    assert rec.metadata == {"source_format": "ui_prmd_kinect", "source_files": [pos.name, ang.name], "movement": 7,
                            "subject": 2, "episode": 3, "correct": True, "timestamps": "assumed_30hz",
                            "confidence": "assumed_tracked", "fixed_rate": True, "floor_referenced": True,
                            "lab": "ui_prmd"}
    assert read_ui_prmd_kinect(pos, ang).equals(rec)


def test_kinect_axes_are_kinect_v2_camera_space(tmp_path):
    """The subject faces the sensor: its left is on the sensor's right (-x), up is +y, it stands at +z."""
    pos, *_ = _kinect_files(tmp_path)
    P = read_ui_prmd_kinect(pos).cameras[0].skeleton.positions[0]
    j = UI_PRMD.index
    np.testing.assert_allclose(P[0], [-0.05, 0.90, 2.40], atol=1e-12)
    assert P[j("UpperArmLeft"), 0] < P[j("Chest"), 0] < P[j("UpperArmRight"), 0]
    assert P[j("HeadTip"), 1] > P[j("Chest"), 1] > P[j("Waist"), 1] > P[j("FootLeft"), 1]
    assert P[j("ToesLeft"), 2] < P[j("FootLeft"), 2] - 0.1  # the toes point at the sensor
    assert P[j("HandLeft"), 1] < P[j("UpperArmLeft"), 1] - 0.4  # the hanging arm of frame 0
    np.testing.assert_array_equal(R_CAM_FILE @ R_CAM_FILE.T, np.eye(3))
    assert np.linalg.det(R_CAM_FILE) == pytest.approx(1.0)


def test_kinect_incorrect_episode_plain_text_and_same_folder(tmp_path):
    p, a = episode_rows(4)
    pos = write_rows(tmp_path / "m10_s05_e09_positions_inc.txt", p, compress=False)
    ang = write_rows(tmp_path / "m10_s05_e09_angles_inc.txt", a, compress=False)
    assert angles_file_for(pos) == ang
    rec = read_ui_prmd_kinect(pos)
    assert rec.metadata["correct"] is False and rec.metadata["movement"] == 10 and rec.cameras[0].skeleton.n_frames == 4
    assert episode_info(tmp_path / "other.txt.gz") == {"movement": None, "subject": None, "episode": None,
                                                       "correct": None}


def test_kinect_angles_file_missing_or_of_another_episode(tmp_path):
    pos, ang, *_ = _kinect_files(tmp_path)
    ang.unlink()
    with pytest.raises(RecordingError, match="angles file is missing") as exc:
        read_ui_prmd_kinect(pos)
    assert str(pos) in str(exc.value) and str(ang) in str(exc.value)
    odd = write_rows(tmp_path / "odd.txt.gz", episode_rows()[0])
    with pytest.raises(RecordingError, match="give the angles file"):
        read_ui_prmd_kinect(odd)
    _, other, *_ = _kinect_files(tmp_path, "m07_s02_e04")
    with pytest.raises(BadInputError, match="different episodes"):
        read_ui_prmd_kinect(pos, other)
    with pytest.raises(BadInputError, match="positions file first"):
        read_ui_prmd_kinect(other, pos)


def test_episodes_of_one_person_joined_with_a_frame_left_out_between(tmp_path):
    """A person's repetitions as one recording: each starts two periods after the previous one ends,
    so no second difference spans a cut, and the timestamps say they are not a camera's clock."""
    episodes = [read_ui_prmd_kinect(_kinect_files(tmp_path, f"m07_s02_e0{e}", n_frames=n)[0]) for e, n in ((1, 5), (2, 4))]
    rec = join_episodes(episodes)
    s = rec.cameras[0].skeleton
    np.testing.assert_allclose(s.timestamps, np.r_[np.arange(5), 6 + np.arange(4)] / 30.0, atol=1e-12)
    np.testing.assert_array_equal(s.positions[5:], episodes[1].cameras[0].skeleton.positions)
    assert rec.metadata["fixed_rate"] is True and rec.metadata["subject"] == 2 and rec.metadata["movement"] == 7
    assert [e["first_frame"] for e in rec.metadata["episodes"]] == [0, 6]
    assert len(rec.metadata["source_files"]) == 4
    other = read_ui_prmd_kinect(_kinect_files(tmp_path, "m07_s03_e01")[0])
    with pytest.raises(BadInputError, match="one person"):
        join_episodes([episodes[0], other])


def test_kinect_needs_kinect_v2_intrinsics(tmp_path):
    pos, *_ = _kinect_files(tmp_path)
    with pytest.raises(BadInputError, match="Kinect v2"):
        read_ui_prmd_kinect(pos, intrinsics=Intrinsics(axes=AxisConvention.OPENCV))


# --------------------------------------------------------------------------------------------------
# Vicon reader


def test_vicon_round_trip_units_axes_and_rate(tmp_path):
    rows = _vicon_rows()
    md = read_ui_prmd_vicon(write_rows(tmp_path / "Vicon" / "Positions" / "m07_s01_e01_positions.txt.gz", rows))
    assert md.names == VICON_MARKERS and len(set(md.names)) == 39
    np.testing.assert_allclose(md.positions, rows.reshape(5, 39, 3) / 1000.0, atol=1e-15)
    np.testing.assert_allclose(md.times, np.arange(5) / 100.0)


def test_vicon_zero_markers_are_absent_also_for_a_whole_episode(tmp_path):
    rows = _vicon_rows().reshape(5, 39, 3)
    strn, lwrb, lelb = (VICON_MARKERS.index(m) for m in ("STRN", "LWRB", "LELB"))
    rows[:, lwrb] = 0.0  # lost for the whole episode
    rows[2, strn] = 0.0  # lost in one frame
    rows[3, lelb, 0] = 0.0  # one coordinate zero: a real place, kept
    md = read_ui_prmd_vicon(write_rows(tmp_path / "v.txt.gz", rows.reshape(5, -1)))
    absent = np.isnan(md.positions).any(axis=-1)
    assert absent[:, lwrb].all() and absent[:, strn].tolist() == [False, False, True, False, False]
    assert absent.sum() == 6 and md.positions[3, lelb, 0] == 0.0
    joints = apply_marker_map(md, load_marker_map("plug_in_gait"))
    wrist = KINECT_V2.index("WristLeft")
    assert np.isnan(joints.positions[:, wrist]).all() and (joints.confidence[:, wrist] == 0).all()


def test_plug_in_gait_map_places_the_joints_it_documents(tmp_path):
    md = read_ui_prmd_vicon(write_rows(tmp_path / "v.txt.gz", _vicon_rows(2)))
    traj = apply_marker_map(md, load_marker_map("plug_in_gait"))
    m = {n: md.positions[:, i] for i, n in enumerate(md.names)}
    j = {n: traj.positions[:, KINECT_V2.index(n)] for n in KINECT_V2.joints}
    np.testing.assert_allclose(j["ShoulderLeft"], m["LSHO"])
    np.testing.assert_allclose(j["ElbowRight"], m["RELB"])
    np.testing.assert_allclose(j["WristLeft"], (m["LWRA"] + m["LWRB"]) / 2)
    np.testing.assert_allclose(j["HipRight"], (m["RASI"] + m["RPSI"]) / 2)
    np.testing.assert_allclose(j["SpineBase"], (m["LASI"] + m["RASI"] + m["LPSI"] + m["RPSI"]) / 4)
    np.testing.assert_allclose(j["SpineShoulder"], (m["C7"] + m["CLAV"]) / 2)
    assert np.isnan(j["Neck"]).all() and np.isnan(j["HandTipLeft"]).all()


# --------------------------------------------------------------------------------------------------
# Bad files


def _kinect_case(tmp_path: Path, edit) -> tuple[Path, Path]:
    p, a = episode_rows(6)
    pos_text = "".join(",".join(f"{v:.6f}" for v in r) + "\n" for r in p)
    ang_text = "".join(",".join(f"{v:.6f}" for v in r) + "\n" for r in a)
    pos_text, ang_text = edit(pos_text, ang_text)
    pos = write_rows(tmp_path / "Kinect" / "Positions" / "m08_s01_e01_positions.txt.gz", pos_text)
    ang = write_rows(tmp_path / "Kinect" / "Angles" / "m08_s01_e01_angles.txt.gz", ang_text)
    return pos, ang


def _replace_line(text: str, k: int, line: str) -> str:
    lines = text.splitlines()
    lines[k] = line
    return "\n".join(lines) + "\n"


def _set_value(text: str, k: int, i: int, value: str) -> str:
    tokens = text.splitlines()[k].split(",")
    tokens[i] = value
    return _replace_line(text, k, ",".join(tokens))


KINECT_CASES = {
    "a row of 65 values": (lambda p, a: (_replace_line(p, 2, ",".join(["1.0"] * 65)), a),
                           "positions", r"line 3: 65 values, .* holds 66"),
    "a Vicon row": (lambda p, a: (_replace_line(p, 0, ",".join(["1.0"] * 117)), a),
                    "positions", r"line 1: 117 values.*looks like a UI-PRMD Vicon"),
    "NaN": (lambda p, a: (_set_value(p, 3, 4, "nan"), a), "positions", r"line 4: value 5 \(Spine y\) is 'nan'"),
    "inf in angles": (lambda p, a: (p, _set_value(a, 1, 65, "1e999")), "angles",
                      r"line 2: value 66 \(ToesRight angle about z\) is '1e999'"),
    "text": (lambda p, a: (_set_value(p, 0, 0, "x"), a), "positions", r"line 1: value 1 \(Waist x\) is 'x'"),
    "a blank line": (lambda p, a: (_replace_line(p, 2, ""), a), "positions", r"line 3: 0 values"),
    "fewer angles rows": (lambda p, a: (p, "".join(a.splitlines(True)[:4])), "positions",
                          r"line 5: no matching row in .*6 frames, .* 4"),
    "more angles rows": (lambda p, a: (p, a + a.splitlines(True)[0]), "angles", r"line 7: no matching row"),
    "an empty positions file": (lambda p, a: ("", a), "positions", r"line 1: the file is empty"),
    "an empty angles file": (lambda p, a: (p, "\n\n"), "angles", r"line 1: the file is empty"),
}


@pytest.mark.parametrize("case", list(KINECT_CASES))
def test_kinect_bad_files_name_the_file_and_line(tmp_path, case):
    edit, culprit, pattern = KINECT_CASES[case]
    pos, ang = _kinect_case(tmp_path, edit)
    with pytest.raises(RecordingError, match=pattern) as exc:
        read_ui_prmd_kinect(pos)
    assert f"{pos if culprit == 'positions' else ang}, line" in str(exc.value)


def _gz_damaged(path: Path, how: str) -> Path:
    data = gzip.compress(("".join(",".join(f"{v:.6f}" for v in r) + "\n" for r in _vicon_rows(40))).encode())
    if how == "truncated":
        data = data[: len(data) // 2]
    elif how == "corrupt":
        data = data[:12] + bytes(b ^ 0xFF for b in data[12:40]) + data[40:]
    elif how == "trailing":
        data = data + b"not gzip"
    elif how == "not gzip":
        data = b"PK\x03\x04 a zip file"
    path.write_bytes(data)
    return path


@pytest.mark.parametrize("how, pattern", [
    ("truncated", r", line \d+: the gzip data ends early .* copy or download"),
    ("corrupt", r", line \d+: the gzip data is corrupt"),
    ("trailing", r"not gzip follows"),
    ("not gzip", r"not gzip data"),
])
def test_damaged_gzip_is_an_error(tmp_path, how, pattern):
    path = _gz_damaged(tmp_path / "m07_s01_e01_positions.txt.gz", how)
    with pytest.raises(RecordingError, match=pattern) as exc:
        read_ui_prmd_vicon(path)
    assert str(path) in str(exc.value)


def test_truncated_gzip_names_the_line_it_ends_in(tmp_path):
    text = "".join(",".join(f"{v:.6f}" for v in r) + "\n" for r in _vicon_rows(40))
    data = gzip.compress(text.encode())
    path = tmp_path / "v.txt.gz"
    path.write_bytes(data[:-8])  # the whole text, without the gzip trailer
    with pytest.raises(RecordingError, match=r"line 41: .* after 40 complete lines"):
        read_ui_prmd_vicon(path)


@pytest.mark.parametrize("rows, pattern", [
    ("", r"line 1: the file is empty"),
    (",".join(["1"] * 66) + "\n", r"line 1: 66 values, .* holds 117.*Kinect"),
    (",".join(["1"] * 116) + ",NaN\n", r"line 1: value 117 \(RTOE z\) is 'NaN'"),
])
def test_vicon_bad_files(tmp_path, rows, pattern):
    path = write_rows(tmp_path / "v.txt.gz", rows)
    with pytest.raises(RecordingError, match=pattern):
        read_ui_prmd_vicon(path)
    with pytest.raises(RecordingError, match="cannot read"):
        read_ui_prmd_vicon(tmp_path / "missing.txt.gz")


# --------------------------------------------------------------------------------------------------
# Real episodes (skipped without the samples)

real = pytest.mark.skipif(not SAMPLES.is_dir(), reason="UI-PRMD samples not present")
EPISODE = "m07_s01_e02"


@real
def test_real_kinect_episode_is_a_standing_person_facing_the_sensor():
    folder = SAMPLES / "Segmented Movements" / "Kinect"
    offsets = np.loadtxt(folder / "Positions" / f"{EPISODE}_positions.txt.gz", delimiter=",").reshape(-1, 22, 3)
    rec = read_ui_prmd_kinect(folder / "Positions" / f"{EPISODE}_positions.txt.gz")
    s = rec.cameras[0].skeleton
    P, j = s.positions, UI_PRMD.index
    bones = UI_PRMD.bones
    length = np.linalg.norm(P[:, bones[:, 1]] - P[:, bones[:, 0]], axis=-1)
    # forward kinematics keeps each frame's offset length exactly; the files' offsets themselves
    # change a little from frame to frame (the tracker's bone lengths), by under 3 cm
    np.testing.assert_allclose(length, np.linalg.norm(offsets[:, bones[:, 1]], axis=-1) / 100, atol=1e-9)
    assert length.std(axis=0).max() < 0.03
    upper_arm = np.linalg.norm(P[:, j("ForearmLeft")] - P[:, j("UpperArmLeft")], axis=-1)
    assert 0.2 < np.median(upper_arm) < 0.4
    assert np.all(P[:, j("HeadTip"), 1] > P[:, j("Waist"), 1] + 0.4)
    assert np.all(P[:, j("Waist"), 1] > P[:, j("FootLeft"), 1] + 0.4)
    assert 1.5 < np.median(P[:, 0, 2]) < 3.5  # in front of the sensor
    assert np.median(P[:, j("UpperArmLeft"), 0]) < np.median(P[:, j("UpperArmRight"), 0])
    assert np.median(P[:, j("ToesLeft"), 2]) < np.median(P[:, j("FootLeft"), 2])  # toes toward the sensor
    right_wrist_rise = P[:, j("HandRight"), 1].max() - P[:, j("HandRight"), 1].min()
    assert right_wrist_rise > 0.5  # m07: shoulder abduction of the right arm
    assert rec.metadata["movement"] == 7 and rec.metadata["subject"] == 1 and rec.metadata["correct"] is True


@real
def test_real_vicon_episode_is_a_standing_person_facing_plus_x():
    md = read_ui_prmd_vicon(SAMPLES / "Segmented Movements" / "Vicon" / "Positions" / f"{EPISODE}_positions.txt.gz")
    m = {n: md.positions[:, i] for i, n in enumerate(md.names)}
    med = {n: np.nanmedian(v, axis=0) for n, v in m.items()}
    assert 0.25 < np.nanmedian(np.linalg.norm(m["LSHO"] - m["LELB"], axis=-1)) < 0.40
    head = np.mean([med[n] for n in ("LFHD", "RFHD", "LBHD", "RBHD")], axis=0)
    pelvis = np.mean([med[n] for n in ("LASI", "RASI", "LPSI", "RPSI")], axis=0)
    assert head[2] > pelvis[2] + 0.4 and 1.3 < head[2] < 2.1
    assert med["LTOE"][2] < 0.15 and med["LTOE"][0] > med["LHEE"][0] + 0.1  # on the floor, facing +x
    assert med["LASI"][1] > med["RASI"][1] + 0.1 and med["LASI"][0] > med["LPSI"][0]  # y left, x forward
    assert np.median(np.diff(md.times)) == pytest.approx(0.01)


@real
def test_real_episodes_last_as_long_on_both_systems_at_30_and_100_hz():
    kinect = SAMPLES / "Segmented Movements" / "Kinect" / "Positions"
    ratios = []
    for pos in sorted(kinect.glob("m0[78]_s0[1-5]_e0[1-2]_positions.txt.gz")):
        k = read_ui_prmd_kinect(pos).cameras[0].skeleton
        v = read_ui_prmd_vicon(pos.parents[2] / "Vicon" / "Positions" / pos.name)
        ratios.append((k.n_frames / 30.0) / (v.times.size / 100.0))
    assert len(ratios) >= 10 and 0.9 < np.median(ratios) < 1.1
