"""Cohort manifests are checked before the Fugl-Meyer analysis loads anything."""

from __future__ import annotations

import json

import pytest

from fusion.errors import RecordingError
from scenarios.clinical.manifest import read_manifest


def _subject(**changes):
    s = {"id": "s1", "group": "healthy", "error": None, "item_scores": {"left": {"hand_lift": 2}},
         "files": {"recording": "r1", "calibration": "c1.toml"},
         "blocks": [{"movement": "salute", "side": "left", "t_start": 0.0, "t_end": 5.0}]}
    return s | changes


def _write(tmp_path, doc):
    (tmp_path / "manifest.json").write_text(doc if isinstance(doc, str) else json.dumps(doc))


def test_a_complete_manifest_is_returned(tmp_path):
    (tmp_path / "r1").mkdir()
    (tmp_path / "c1.toml").write_text("")
    failed = _subject(id="s2", error="CalibrationError: static", files={"recording": "gone", "calibration": None})
    _write(tmp_path, {"subjects": [_subject(), failed]})
    assert [s["id"] for s in read_manifest(tmp_path)["subjects"]] == ["s1", "s2"]  # failed subjects need no files


@pytest.mark.parametrize("doc, message", [
    (None, "has no manifest.json"),
    ("\x00garbage", "not valid JSON"),
    ('{"subjects": [{"id": "s1", "gr', "not valid JSON"),
    ({"subjects": 3}, "no list of subjects"),
    ({"subjects": [{"id": "s1"}]}, "lacks id, group"),
    ({"subjects": [_subject(blocks=[{"movement": "salute", "side": "up", "t_start": 0, "t_end": 1}])]}, "each block"),
    ({"subjects": [_subject(blocks=[{"movement": "salute", "side": "left", "t_start": "x", "t_end": 1}])]},
     "each block"),
    ({"subjects": [_subject(files={"recording": 3})]}, "files must name"),
    ({"subjects": [_subject(item_scores={"right": {}})]}, "item_scores"),
    ({"subjects": [_subject()]}, "recording 'r1' does not exist"),
])
def test_bad_manifests_are_refused(tmp_path, doc, message):
    if doc is not None:
        _write(tmp_path, doc)
    with pytest.raises(RecordingError, match=message):
        read_manifest(tmp_path)
