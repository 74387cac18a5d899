"""The lab a recording comes from, as ``import`` keeps it."""

from __future__ import annotations

from pathlib import Path

from fusion.io.recording_files import load_recording
from scenarios.cli import main


def _kimore_csv(path: Path, frames: int = 4) -> Path:
    row = ",".join(f"{0.1 * j},{-0.2},{2.5},2" for j in range(25))
    path.write_text("\n".join([row] * frames) + "\n")
    return path


def test_a_built_in_layout_names_its_lab_and_import_lab_overrides_it(tmp_path) -> None:
    csv = _kimore_csv(tmp_path / "k.csv")
    assert main(["import", "csv", str(csv), "--layout", "kimore", "--out", str(tmp_path / "a")]) == 0
    assert load_recording(tmp_path / "a").lab == "kimore"
    assert main(["import", "csv", str(csv), "--layout", "kimore", "--lab", "clinic_b", "--out", str(tmp_path / "b")]) == 0
    assert load_recording(tmp_path / "b").lab == "clinic_b"


def test_import_refuses_a_lab_name_a_profile_cannot_hold(tmp_path, capsys) -> None:
    csv = _kimore_csv(tmp_path / "k.csv")
    assert main(["import", "csv", str(csv), "--layout", "kimore", "--lab", "a.b", "--out", str(tmp_path / "a")]) == 2
    assert "a lab name must be a non-empty string without '.'" in capsys.readouterr().err
    assert not (tmp_path / "a").exists()
