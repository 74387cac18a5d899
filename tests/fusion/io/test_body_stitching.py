"""One person re-acquired by the tracker under a new body id is stitched into one track, others are not."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fusion.camera import AxisConvention
from fusion.frames import LengthUnit
from fusion.io.formats import MAX_REACQUIRE_JUMP_M, select_main_body
from fusion.io.formats.csv_skeleton import (
    ConfidenceScale,
    CsvOptions,
    read_csv_skeleton,
)
from fusion.topology import K4ABT, KINECT_V2
from tests.fusion.skeleton_fakes import REST_POSE

SAMPLES = Path(__file__).resolve().parents[3] / ".." / "shared" / "samples" / "azure_2cam"
J = KINECT_V2.n_joints


def _body(bid: int, x: float) -> tuple[int, np.ndarray, np.ndarray]:
    return bid, REST_POSE + [x, 0.0, 2.5], np.full(J, 2, dtype=np.int8)


def _walk(n: int) -> np.ndarray:
    return np.linspace(0.0, 1.0, n)  # 1 m over n frames


@given(n=st.integers(10, 60), cut=st.floats(0.2, 0.8), gap=st.integers(0, 5))
def test_a_reacquired_person_is_stitched(n, cut, gap):
    x = _walk(n)
    k = int(cut * n)
    frames = [[_body(1, x[t])] if t < k else [] if t < k + gap else [_body(2, x[t])] for t in range(n)]
    body_id, positions, states, stitched = select_main_body(frames, J)
    present = ~np.isnan(positions[:, 0, 0])
    assert (body_id, stitched) in ((1, [2]), (2, [1]))
    assert present.sum() == n - gap
    np.testing.assert_allclose(positions[present, 0, 0], REST_POSE[0, 0] + x[present])


def test_someone_else_is_not_stitched():
    x = _walk(30)
    together = [[_body(1, x[t]), _body(2, x[t] + 1.0)] if t < 10 else [_body(1, x[t])] for t in range(30)]
    body_id, _, _, stitched = select_main_body(together, J)
    assert body_id == 1 and stitched == []
    far = [[_body(1, 0.0)] if t < 20 else [_body(2, 3.0)] for t in range(30)]  # 3 m jump in one frame
    body_id, positions, _, stitched = select_main_body(far, J)
    assert body_id == 1 and stitched == [] and np.isnan(positions[20:]).all()
    assert 3.0 > MAX_REACQUIRE_JUMP_M + 0.1


def test_no_body_at_all():
    body_id, positions, states, stitched = select_main_body([[], []], J)
    assert body_id is None and stitched == [] and np.isnan(positions).all() and not states.any()


@pytest.mark.skipif(not SAMPLES.is_dir(), reason="real samples (../shared/samples) absent")
def test_real_azure_session_with_a_new_body_id_keeps_every_frame(tmp_path, caplog):
    """A real Azure Kinect session whose body id changes for 21 % of its frames (as when the tracker
    loses and re-acquires the person) is read as one track with a warning."""
    raw = np.loadtxt(SAMPLES / "1E2DB6_01_master_positions_3d.csv", delimiter=";", skiprows=1)
    n = raw.shape[0]
    ids = raw[:, 1].astype(int)
    ids[int(0.40 * n):int(0.61 * n)] = 2
    header = ["timestamp", "body"] + [f"{j}_{c}" for j in K4ABT.joints for c in ("conf", "x", "y", "z")]
    cells = [[f"{int(v)}" if k % 4 == 0 else repr(float(v)) for k, v in enumerate(r)] for r in raw[:, 2:]]
    rows = [",".join([repr(float(t) / 1e6), str(b), *c]) for t, b, c in zip(raw[:, 0], ids, cells)]
    path = tmp_path / "master.csv"
    path.write_text("\n".join([",".join(header), *rows]) + "\n")
    options = CsvOptions(topology=K4ABT, unit=LengthUnit.MM, axes=AxisConvention.OPENCV,
                         confidence=ConfidenceScale.STATE_0_3)
    with caplog.at_level(logging.WARNING):
        rec = read_csv_skeleton(path, options)
    s = rec.cameras[0].skeleton
    with_joints = (raw[:, 2::4] > 0).any(axis=1)
    kept = ~np.isnan(s.positions[..., 0]).all(axis=1)
    assert s.n_frames == n and kept.sum() == with_joints.sum()
    assert rec.metadata["stitched_body_ids"] == {"master": [2]} and rec.metadata["body_ids"] == {"master": 1}
    assert "re-acquired under body id(s) 2" in caplog.text
