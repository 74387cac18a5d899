"""calib-study: a seed the body cannot calibrate is a result (listed under the table), not the end of the study."""

from __future__ import annotations

import json

import numpy as np
import pytest

from fusion.errors import CalibrationError
from scenarios.studies.calib_study import write_study


def _run(seed: int, error_deg: float) -> dict:
    T = np.eye(4)
    T[:3, 3] = [1.0, 0.0, 0.1 * seed]
    variant = {"rotation_error_deg": {"cam1": 0.0, "cam2": error_deg}, "translation_error_mm": {"cam1": 0.0, "cam2": 10.0},
               "rmse_points_mm": {"cam1": 0.0, "cam2": 5.0}, "T_ref_cam": {"cam1": np.eye(4).tolist(), "cam2": T.tolist()},
               "loop_closure_mm": None, "elbow_flexion_deg": 3.0, "ht_elevation_deg": 2.0}
    return {"seed": seed, "reference": "cam1", "variants": {"skeleton+chain": variant},
            "body_ref_cam": [[0.0, 0.0, 2.0], [0.1, 0.3, 2.2]]}


def test_a_seed_that_cannot_be_calibrated_is_listed_and_the_others_summarised(tmp_path):
    failed = {"seed": 2, "variants": {}, "failed": "cameras ['cam2'] cannot be reached from reference 'cam1'"}
    summary = write_study(tmp_path / "s", "t", [_run(1, 1.0), failed, _run(3, 3.0)])
    assert summary["skeleton+chain"]["rotation_error_deg"][0] == pytest.approx(2.0)  # median of seeds 1 and 3
    table = (tmp_path / "s" / "table1.md").read_text()
    assert "Calibrated 2 of 3 seeds" in table and "seed 2: cameras ['cam2'] cannot be reached" in table
    doc = json.loads((tmp_path / "s" / "study.json").read_text())
    assert doc["failed"] == {"2": failed["failed"]} and [r["seed"] for r in doc["runs"]] == [1, 3]
    with pytest.raises(CalibrationError, match="no seed could be calibrated, e.g. seed 2"):
        write_study(tmp_path / "t", "t", [failed])
    assert not (tmp_path / "t").exists()
