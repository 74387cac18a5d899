"""UI-PRMD files at the command line: ``import ui-prmd-kinect`` of an episode written here, and
``retarget`` of a Vicon file whose Plug-in-Gait markers are placed on a known motion of the humanoid."""

from __future__ import annotations

import gzip
import re
from pathlib import Path

import numpy as np
import pytest

from fusion.io.formats.ui_prmd import VICON_MARKERS
from fusion.io.recording_files import load_recording, save_recording
from fusion.merge.sensor_stats import sensor_stats
from fusion.topology import K4ABT, KINECT_V2, UI_PRMD
from scenarios.cli import main
from sim.anthropometry import Anthropometry
from sim.coordinates import INDEX
from sim.humanoid_model import build_humanoid
from sim.motions import hand_lift
from sim.patient_motion import Movement, Side, SubjectProfile
from sim.replay import load_motion
from sim.retarget import joint_groups
from sim.sensor_profile import load_profile
from tests.fusion.io.test_recording import small_recording
from tests.fusion.io.ui_prmd_files import episode_rows, write_rows


def _kinect_episode(root: Path, name: str = "m09_s03_e07") -> Path:
    p, a = episode_rows(8)
    write_rows(root / "Kinect" / "Angles" / f"{name}_angles.txt.gz", a)
    return write_rows(root / "Kinect" / "Positions" / f"{name}_positions.txt.gz", p)


def test_import_ui_prmd_kinect(tmp_path, capsys):
    pos = _kinect_episode(tmp_path)
    assert main(["import", "ui-prmd-kinect", str(pos), "--out", str(tmp_path / "rec")]) == 0
    assert "kinect: 8 frames, ui_prmd" in capsys.readouterr().out
    rec = load_recording(tmp_path / "rec")
    assert rec.topology == UI_PRMD and rec.camera_names == ("kinect",)
    assert rec.metadata["movement"] == 9 and rec.metadata["subject"] == 3 and rec.metadata["episode"] == 7
    angles = tmp_path / "Kinect" / "Angles" / "m09_s03_e07_angles.txt.gz"
    assert main(["import", "ui-prmd-kinect", str(pos), str(angles), "--out", str(tmp_path / "rec2")]) == 0
    assert load_recording(tmp_path / "rec2").equals(rec)
    assert rec.lab == "ui_prmd"  # the dataset's lab, unless import says another
    assert main(["import", "ui-prmd-kinect", str(pos), "--lab", "lab_b", "--out", str(tmp_path / "rec3")]) == 0
    assert load_recording(tmp_path / "rec3").lab == "lab_b"


def test_import_ui_prmd_kinect_errors(tmp_path, capsys):
    pos = _kinect_episode(tmp_path)
    angles = tmp_path / "Kinect" / "Angles" / "m09_s03_e07_angles.txt.gz"
    assert main(["import", "ui-prmd-kinect", str(pos), str(angles), str(pos), "--out", str(tmp_path / "x")]) == 2
    assert "one episode" in capsys.readouterr().err
    angles.unlink()
    assert main(["import", "ui-prmd-kinect", str(pos), "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert str(pos) in err and "angles file is missing" in err
    with pytest.raises(SystemExit):  # read only: not a choice of write
        main(["write", "ui-prmd-kinect", str(tmp_path), "--out", str(tmp_path / "w")])


def test_ui_prmd_episodes_joined_measured_and_fitted_as_a_kinect_v2(tmp_path, capsys):
    """A person's episodes import as one recording; its truth-free statistics leave out the hands it
    lacks and the confidences its files do not carry; ``sensor-fit`` fits the Kinect v2 it came from,
    and ``sim-to-real`` compares it with a simulated Kinect v2 reduced to its joints."""
    files = []
    for e in range(1, 4):
        p, a = episode_rows(30)
        write_rows(tmp_path / "Kinect" / "Angles" / f"m07_s01_e0{e}_angles.txt.gz", a)
        files.append(str(write_rows(tmp_path / "Kinect" / "Positions" / f"m07_s01_e0{e}_positions.txt.gz", p)))
    assert main(["import", "ui-prmd-kinect", *files, "--out", str(tmp_path / "rec")]) == 0
    assert "kinect: 90 frames, ui_prmd" in capsys.readouterr().out
    rec = load_recording(tmp_path / "rec")
    assert [e["episode"] for e in rec.metadata["episodes"]] == [1, 2, 3]
    stats = sensor_stats(rec, n_boot=0, rng=np.random.default_rng(0))
    assert "hand" not in stats.jitter_mm and {"wrist", "elbow", "head"} <= set(stats.jitter_mm)
    assert np.isnan(stats.confidence2["all"].value)  # assumed by the reader, not measured
    assert main(["sensor-fit", str(tmp_path / "rec"), "--out", str(tmp_path / "p.toml")]) == 0
    assert load_profile(tmp_path / "p.toml").topology == KINECT_V2
    capsys.readouterr()
    assert main(["sim-to-real", str(tmp_path / "rec"), "--out", str(tmp_path / "s2r")]) == 0
    table = capsys.readouterr().out
    assert re.search(r"\| rec \| share of joints at confidence 2 \| - \| [0-9.]+ % \| - \| - \|", table)  # not in the files
    assert main(["import", "ui-prmd-kinect", files[0], files[1].replace("Positions", "Angles").replace("positions", "angles"),
                 files[2], "--out", str(tmp_path / "x")]) == 2
    assert "one episode" in capsys.readouterr().err
    save_recording(small_recording(K4ABT, with_depth=False), tmp_path / "azure")
    assert main(["sensor-fit", str(tmp_path / "rec"), str(tmp_path / "azure"), "--out", str(tmp_path / "q.toml")]) == 2
    assert "come from different trackers (k4abt, kinect_v2)" in capsys.readouterr().err
    assert not (tmp_path / "q.toml").exists()


@pytest.fixture(scope="module")
def vicon_clip():
    """A right-arm hand lift of a 1.72 m humanoid as Plug-in-Gait markers [mm], 100 Hz, such that the
    ``plug_in_gait`` map gives back the humanoid's Kinect v2 joints (other markers on nearby joints)."""
    rng = np.random.default_rng(5)
    motion = hand_lift(Side.RIGHT, 1, SubjectProfile.healthy().movement(Movement.HAND_LIFT, Side.RIGHT), rng=rng)
    t = np.arange(0.0, motion.duration, 0.01)
    coords = motion.sample(t)
    joints = build_humanoid(Anthropometry(height_m=1.72)).joint_positions(coords, KINECT_V2)
    j = {n: joints[:, KINECT_V2.index(n)] for n in KINECT_V2.joints}
    forward = np.array([0.08, 0.0, 0.0])  # the iliac spines 8 cm in front of and behind the hip
    m = {"LFHD": j["Head"], "RFHD": j["Head"], "LBHD": j["Head"], "RBHD": j["Head"], "C7": j["SpineShoulder"],
         "CLAV": j["SpineShoulder"], "T10": j["SpineMid"], "STRN": j["SpineMid"], "RBAK": j["SpineMid"],
         "LASI": j["HipLeft"] + forward, "LPSI": j["HipLeft"] - forward, "RASI": j["HipRight"] + forward,
         "RPSI": j["HipRight"] - forward}
    for s, side in (("L", "Left"), ("R", "Right")):
        m |= {f"{s}SHO": j[f"Shoulder{side}"], f"{s}UPA": j[f"Shoulder{side}"], f"{s}ELB": j[f"Elbow{side}"],
              f"{s}FRM": j[f"Elbow{side}"], f"{s}WRA": j[f"Wrist{side}"], f"{s}WRB": j[f"Wrist{side}"],
              f"{s}FIN": j[f"Hand{side}"], f"{s}THI": j[f"Knee{side}"], f"{s}KNE": j[f"Knee{side}"],
              f"{s}TIB": j[f"Ankle{side}"], f"{s}ANK": j[f"Ankle{side}"], f"{s}HEE": j[f"Ankle{side}"],
              f"{s}TOE": j[f"Foot{side}"]}
    rows = np.stack([m[n] for n in VICON_MARKERS], axis=1).reshape(t.size, -1) * 1000.0
    return coords, rows


def test_retarget_a_ui_prmd_vicon_file(tmp_path, vicon_clip, capsys):
    coords, rows = vicon_clip
    clip = write_rows(tmp_path / "Vicon" / "Positions" / "m07_s01_e01_positions.txt.gz", rows)
    out = tmp_path / "m.npz"
    assert main(["retarget", str(clip), "--out", str(out)]) == 0
    assert "stature 1.7" in capsys.readouterr().out
    m = load_motion(out)
    assert m.coords.shape == coords.shape and m.converged.all()
    np.testing.assert_allclose(m.times, np.arange(len(rows)) / 100.0)
    groups = joint_groups(KINECT_V2)
    for group in ("trunk", "left arm", "right arm", "left leg", "right leg"):
        e = m.errors[:, groups == group]
        assert np.median(e[np.isfinite(e)]) < 0.002, group
    err = np.degrees(np.abs(m.coords[:, INDEX["sh_elevation_r"]] - coords[:, INDEX["sh_elevation_r"]]))
    assert np.median(err) < 1.0


def test_retarget_guesses_a_vicon_file_only_when_its_folder_says_so(tmp_path, vicon_clip, capsys):
    rows = vicon_clip[1][:60]
    elsewhere = write_rows(tmp_path / "m07_s01_e01_positions.txt.gz", rows)
    assert main(["retarget", str(elsewhere), "--out", str(tmp_path / "a.npz")]) == 2
    assert "ui-prmd-vicon" in capsys.readouterr().err
    assert main(["retarget", str(elsewhere), "--format", "ui-prmd-vicon", "--out", str(tmp_path / "a.npz")]) == 0
    assert main(["retarget", str(elsewhere), "--format", "ui-prmd-vicon", "--units", "cm",
                 "--out", str(tmp_path / "b.npz")]) == 2
    assert "millimetres" in capsys.readouterr().err
    kinect = _kinect_episode(tmp_path)
    assert main(["retarget", str(kinect), "--out", str(tmp_path / "c.npz")]) == 2
    assert "import ui-prmd-kinect" in capsys.readouterr().err
    gz = gzip.compress(b"")
    (tmp_path / "Vicon").mkdir(exist_ok=True)
    (tmp_path / "Vicon" / "m07_s01_e02_positions.txt.gz").write_bytes(gz)
    assert main(["retarget", str(tmp_path / "Vicon" / "m07_s01_e02_positions.txt.gz"), "--out",
                 str(tmp_path / "d.npz")]) == 2
    assert "empty" in capsys.readouterr().err
