import hashlib
import json

import numpy as np
import pytest

from fusion.calibration import Calibration
from fusion.errors import BadInputError, RecordingError
from fusion.io.calibration_file import save_calibration
from fusion.io.depth_store import StoredFrames
from fusion.io.recording_files import load_recording
from fusion.topology import KINECT_V2
from scenarios.cli import main
from scenarios.config import load_scenario
from scenarios.runner import load_run, simulate, simulate_to_disk
from sim.depth_renderer import auto_choice
from sim.gl_depth import probe_gl
from sim.truth import load_truth

SHORT = 3.0


def _digest(directory):
    h = hashlib.sha256()
    for p in sorted(directory.rglob("*")):
        if p.is_file():
            h.update(str(p.relative_to(directory)).encode())
            h.update(p.read_bytes())
    return h.hexdigest()


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    base = tmp_path_factory.mktemp("runs")
    scenario = load_scenario("fma_2cam")
    for name, seed in (("a", 5), ("b", 5), ("c", 6)):
        simulate_to_disk(scenario, base / name, seed=seed, duration_s=SHORT, progress=False)
    return base


def test_same_seed_is_byte_identical_and_other_seed_differs(runs):
    assert _digest(runs / "a") == _digest(runs / "b")
    a, _ = load_run(runs / "a")
    c, _ = load_run(runs / "c")
    pa, pc = a.cameras[0].skeleton.positions, c.cameras[0].skeleton.positions
    n = min(len(pa), len(pc))
    assert not np.allclose(pa[:n], pc[:n], equal_nan=True)


def test_run_contents(runs):
    rec, truth = load_run(runs / "a")
    assert rec.camera_names == truth.camera_names == ("cam1", "cam2")
    assert rec.topology == KINECT_V2
    doc = json.loads((runs / "a" / "scenario.json").read_text())
    assert doc["seed"] == 5 and doc["scenario"]["name"] == "fma_2cam"
    for cam, ct in zip(rec.cameras, truth.cameras):
        assert cam.skeleton.n_frames == ct.true_times.shape[0]
        assert 2.5 * 30 < cam.skeleton.n_frames <= SHORT * 30
        assert cam.depth.n_frames == 3 and cam.depth.depth_mm.shape == (3, 424, 512)
        # timestamps are on the camera clock: true time + offset (+ jitter)
        np.testing.assert_allclose(cam.skeleton.timestamps - ct.true_times, ct.clock_offset_s, atol=0.005)
    # the observation carries no truth
    assert "T_world_cam" not in json.dumps(rec.metadata)


def test_depth_streamed_to_disk_equals_the_in_memory_run(runs):
    in_memory, _ = simulate(load_scenario("fma_2cam").replace(seed=5, duration_s=SHORT), progress=False)
    on_disk, _ = load_run(runs / "a")
    assert isinstance(on_disk.cameras[0].depth.depth_mm, StoredFrames)  # read lazily
    assert isinstance(in_memory.cameras[0].depth.depth_mm, np.ndarray)
    assert on_disk.equals(in_memory)


def test_truth_bone_lengths_are_constant(runs):
    _, truth = load_run(runs / "a")
    j = truth.joints_world
    lengths = np.linalg.norm(j[:, KINECT_V2.bones[:, 0]] - j[:, KINECT_V2.bones[:, 1]], axis=-1)
    assert np.ptp(lengths, axis=0).max() < 1e-9


def test_existing_output_is_kept(runs):
    before = _digest(runs / "a")
    with pytest.raises(BadInputError, match="not empty"):
        simulate_to_disk(load_scenario("single"), runs / "a", duration_s=1.0, progress=False)
    assert _digest(runs / "a") == before


def test_truncated_truth_is_reported(runs, tmp_path):
    import shutil

    shutil.copytree(runs / "a", tmp_path / "r")
    f = tmp_path / "r" / "truth" / "cam1" / "joints_world.npy"
    f.write_bytes(f.read_bytes()[:100])
    with pytest.raises(RecordingError, match="truncated"):
        load_truth(tmp_path / "r" / "truth")


def test_cli_simulate_and_show(tmp_path, capsys):
    assert main(["simulate", "single", "--out", str(tmp_path / "run"), "--seed", "2", "--duration", "2"]) == 0
    assert load_recording(tmp_path / "run" / "recording").camera_names == ("cam1",)
    assert main(["show", str(tmp_path / "run"), "--out", str(tmp_path / "png")]) == 0
    pngs = sorted(p.name for p in (tmp_path / "png").iterdir())
    assert pngs == ["depth_cam1.png", "top_view.png"]
    assert (tmp_path / "png" / "top_view.png").read_bytes()[:4] == b"\x89PNG"


def test_cli_show_real_recording_with_calibration(tmp_path, capsys):
    assert main(["simulate", "fma_2cam", "--out", str(tmp_path / "run"), "--seed", "1", "--duration", "3"]) == 0
    assert main(["show", str(tmp_path / "run" / "recording"), "--out", str(tmp_path / "png")]) == 2
    assert "--calib" in capsys.readouterr().err
    truth = load_truth(tmp_path / "run" / "truth")
    cal = Calibration({c.name: c.T_world_cam for c in truth.cameras},
                      {c.name: c.intrinsics for c in load_recording(tmp_path / "run" / "recording").cameras},
                      {c.name: 0.0 for c in truth.cameras}, truth.cameras[0].name)
    save_calibration(cal, tmp_path / "calib.toml")
    assert main(["show", str(tmp_path / "run" / "recording"), "--calib", str(tmp_path / "calib.toml"),
                 "--out", str(tmp_path / "png")]) == 0
    assert (tmp_path / "png" / "top_view.png").read_bytes()[:4] == b"\x89PNG"


def test_cli_chooses_the_depth_renderer(tmp_path):
    args = ["simulate", "single", "--seed", "2", "--duration", "1"]
    assert main(args + ["--out", str(tmp_path / "ray"), "--depth-renderer", "raycast"]) == 0
    assert load_recording(tmp_path / "ray" / "recording").metadata["depth_renderer"] == "raycast"
    assert main(args + ["--out", str(tmp_path / "auto")]) == 0
    expected = auto_choice(*probe_gl())[0].value  # MuJoCo's renderer on hardware OpenGL only
    assert load_recording(tmp_path / "auto" / "recording").metadata["depth_renderer"] == expected


def test_cli_errors_are_clear(tmp_path, capsys):
    assert main(["simulate", "nonexistent", "--out", str(tmp_path / "x")]) == 2
    assert "built-in" in capsys.readouterr().err
    assert main(["show", str(tmp_path / "missing"), "--out", str(tmp_path / "png")]) == 2
    assert "error" in capsys.readouterr().err
