"""Retargeting C3D, TRC and BVH clips written here from a known motion of the humanoid: residuals per
joint group and shoulder and elbow angles against the motion that made the clip; the report over
several sources."""

from __future__ import annotations

import numpy as np
import pytest

from fusion.camera import KINECT_V2_DEPTH
from fusion.io.export import export_c3d, export_trc
from fusion.io.recording_files import save_recording
from fusion.recording import CameraRecording, Recording
from fusion.skeleton import SkeletonStream
from fusion.topology import KINECT_V2, TrackingState
from fusion.transforms import apply, invert
from scenarios.cli import main
from sim.anthropometry import Anthropometry
from sim.coordinates import INDEX
from sim.humanoid_model import build_humanoid
from sim.motions import hand_lift, salute
from sim.patient_motion import Movement, Side, SubjectProfile
from sim.replay import load_motion
from sim.retarget import joint_groups
from sim.rig import look_at
from sim.timeline import compose
from tests.scenarios.interop.mocap_clips import write_bvh

HEIGHT_M = 1.68

# Largest median and 99th-percentile residual per joint group [m]: the clips hold the humanoid's own
# joints (C3D in single-precision millimetres, TRC in micrometres, BVH in centimetres with angles in
# micro-degrees), so what is left is the fit.
MEDIAN_M, P99_M = 0.0005, 0.002


@pytest.fixture(scope="module")
def known():
    """A right-arm hand lift, then a left-arm salute (knees and trunk bend), of a 1.68 m subject."""
    rng = np.random.default_rng(2)
    healthy = SubjectProfile.healthy()
    motion = compose([hand_lift(Side.RIGHT, 1, healthy.movement(Movement.HAND_LIFT, Side.RIGHT), rng=rng),
                      salute(Side.LEFT, 1, healthy.movement(Movement.SALUTE, Side.LEFT), rng=rng)])
    t = np.arange(0.0, motion.duration, 1 / 30)
    coords = motion.sample(t)
    humanoid = build_humanoid(Anthropometry(height_m=HEIGHT_M))
    return humanoid, t, coords, humanoid.joint_positions(coords, KINECT_V2)


def _write(fmt, path, known):
    humanoid, t, coords, joints = known
    if fmt == "bvh":
        return write_bvh(path, humanoid, t, coords)
    stream = SkeletonStream(KINECT_V2, t, joints, np.full(joints.shape[:2], TrackingState.TRACKED, np.int8))
    return (export_c3d if fmt == "c3d" else export_trc)(stream, path)


@pytest.mark.parametrize("fmt", ["c3d", "trc", "bvh"])
def test_a_clip_of_a_known_motion_retargets_to_that_motion(tmp_path, known, capsys, fmt):
    _, _, coords, _ = known
    clip = _write(fmt, tmp_path / f"clip.{fmt}", known)
    out = tmp_path / "m.npz"
    assert main(["retarget", str(clip), "--out", str(out)]) == 0
    assert f"stature {HEIGHT_M:.2f}" in capsys.readouterr().out
    m = load_motion(out)
    assert m.coords.shape == coords.shape and m.converged.all()
    groups = joint_groups(KINECT_V2)
    for group in ("trunk", "left arm", "right arm", "left leg", "right leg"):
        e = m.errors[:, groups == group]
        e = e[np.isfinite(e)]
        assert np.median(e) < MEDIAN_M and np.percentile(e, 99) < P99_M, (group, np.median(e), np.percentile(e, 99))
    for side in "lr":
        for name in (f"sh_elevation_{side}", f"elbow_flexion_{side}"):
            err = np.degrees(np.abs(m.coords[:, INDEX[name]] - coords[:, INDEX[name]]))
            assert np.median(err) < 0.2 and err.max() < 2.0, (name, np.median(err), err.max())
    np.testing.assert_allclose(m.coords[:, [INDEX["root_x"], INDEX["root_y"]]],
                               coords[:, [INDEX["root_x"], INDEX["root_y"]]], atol=0.005)


def test_retarget_report_tabulates_every_source(tmp_path, known, capsys):
    _, t, _, joints = known
    clip = _write("trc", tmp_path / "clip.trc", known)
    # one level Kinect v2 camera 2.5 m in front of the subject: its frame turned upright is the world moved
    T_world_cam = look_at([2.5, 0.3, 1.0], [0.0, 0.3, 1.0])
    positions = apply(invert(T_world_cam), joints.reshape(-1, 3)).reshape(joints.shape)
    states = np.full(joints.shape[:2], TrackingState.TRACKED, np.int8)
    camera = CameraRecording("front", KINECT_V2_DEPTH, SkeletonStream(KINECT_V2, t, positions, states))
    one_camera = save_recording(Recording((camera,)), tmp_path / "one_camera")
    report = tmp_path / "report.md"
    assert main(["retarget-report", str(clip), str(one_camera), "--out", str(report)]) == 0
    rows = [line.split(" | ") for line in report.read_text().splitlines() if line.startswith(f"| {tmp_path}")]
    assert [r[0][2:] for r in rows] == [str(clip), str(one_camera)]
    for row in rows:
        assert row[1] == str(t.size) and row[2] == "0" and row[3] == f"{HEIGHT_M:.3f}"
        medians = [float(cell.split(" (")[0]) for cell in row[5:]]
        assert len(medians) == 5 and max(medians) < 0.5  # mm
    assert "wrote" in capsys.readouterr().out
    assert main(["retarget-report", str(clip), "--out", str(report)]) == 2  # kept without --overwrite
