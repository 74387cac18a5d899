"""Study pages: provenance, fingerprints, stale notices, regeneration, and the docs' own pages."""

from __future__ import annotations

from pathlib import Path

import pytest

from fusion.errors import BadInputError, ScenarioError
from scenarios.cli import main
from scenarios.studies.pages import (
    Status,
    check_pages,
    fingerprint,
    load_registry,
    mark_pages,
    read_provenance,
    regenerate,
)

ROOT = Path(__file__).resolve().parents[3]
PROFILE = ROOT / "sim" / "sensor_profiles" / "kinect_v2.toml"


def test_the_docs_study_pages_record_what_made_them_and_say_when_they_are_stale():
    statuses = check_pages(ROOT / "docs" / "studies", ROOT)
    assert len(statuses) >= 20
    assert all(s.status is not Status.UNRECORDED for s in statuses)
    wrong = [s.study.page for s in statuses if not s.honest]
    assert not wrong, f"pages whose stale notice disagrees with their inputs (mocap-bench studies --mark): {wrong}"


def test_a_profile_fingerprint_follows_its_values_not_their_sources(tmp_path):
    text = PROFILE.read_text()
    base = fingerprint(PROFILE)
    reworded = tmp_path / "a.toml"
    reworded.write_text(text.replace("[provenance]", "[provenance]\n\"note\" = \"reworded\""))
    assert fingerprint(reworded) == base
    noise = tmp_path / "b.toml"
    noise.write_text(text.replace("flying_prob = 0.5", "flying_prob = 0.5000000000000001"))
    assert fingerprint(noise) == base
    changed = tmp_path / "c.toml"
    changed.write_text(text.replace("flying_prob = 0.5", "flying_prob = 0.6"))
    assert fingerprint(changed) != base
    assert fingerprint(tmp_path / "absent.toml") == "missing"


def test_an_idle_body_scale_does_not_change_a_fingerprint(tmp_path):
    text = PROFILE.read_text()
    assert "body_scale_sd = 0.0" in text
    base = fingerprint(PROFILE)
    without = tmp_path / "a.toml"  # as written before the body scale existed
    without.write_text("\n".join(line for line in text.splitlines() if not line.startswith("body_scale_")))
    assert fingerprint(without) == base
    slower = tmp_path / "b.toml"
    slower.write_text(text.replace("body_scale_tau_s = 0.5", "body_scale_tau_s = 2.0"))
    assert fingerprint(slower) == base  # nothing to slow down
    scaled = tmp_path / "c.toml"
    scaled.write_text(text.replace("body_scale_sd = 0.0", "body_scale_sd = 0.03"))
    assert fingerprint(scaled) != base
    scaled_slower = tmp_path / "d.toml"
    scaled_slower.write_text(scaled.read_text().replace("body_scale_tau_s = 0.5", "body_scale_tau_s = 2.0"))
    assert fingerprint(scaled_slower) != fingerprint(scaled)


def _registry(tmp_path: Path) -> Path:
    folder = tmp_path / "docs" / "studies"
    folder.mkdir(parents=True)
    (tmp_path / "input.toml").write_text("[scenario]\nname = \"x\"\nseed = 1\n")
    (folder / "studies.toml").write_text(
        '[[study]]\nname = "demo_page"\npage = "demo_page.md"\ninputs = ["input.toml"]\n'
        'commands = ["fake --out {out}"]\ncopy = { "report.md" = "demo_page.md", "pic.png" = "demo_page.png" }\n')
    return folder


def _fake_main(argv: list[str]) -> int:
    out = Path(argv[argv.index("--out") + 1])
    out.mkdir(parents=True)
    (out / "report.md").write_text("# Demo\n\n![picture](pic.png)\n")
    (out / "pic.png").write_bytes(b"\x89PNG\r\n\x1a\n")
    return 0


def test_regenerated_page_is_stamped_then_marked_stale_when_an_input_changes(tmp_path):
    folder = _registry(tmp_path)
    (study,) = load_registry(folder)
    written = regenerate(study, folder, tmp_path, _fake_main)
    assert sorted(p.name for p in written) == ["demo_page.md", "demo_page.png"]
    text = (folder / "demo_page.md").read_text()
    assert "demo_page.png" in text and "(pic.png)" not in text
    prov = read_provenance(folder / "demo_page.md")
    assert prov.command == "fake --out OUT" and "`mocap-bench fake --out OUT`" in text
    assert [s.status for s in check_pages(folder, tmp_path)] == [Status.FRESH]

    (tmp_path / "input.toml").write_text("[scenario]\nname = \"x\"\nseed = 2\n")
    (s,) = check_pages(folder, tmp_path)
    assert s.status is Status.STALE and s.changed == ("input.toml",) and not s.honest
    (s,) = mark_pages(folder, tmp_path)
    assert s.honest and "Older than its inputs" in (folder / "demo_page.md").read_text()

    (tmp_path / "input.toml").write_text("[scenario]\nname = \"x\"\nseed = 1\n")
    (s,) = mark_pages(folder, tmp_path)
    assert s.status is Status.FRESH and "Older than its inputs" not in (folder / "demo_page.md").read_text()


def test_a_failing_command_changes_nothing(tmp_path):
    folder = _registry(tmp_path)
    (study,) = load_registry(folder)
    (folder / "demo_page.md").write_text("kept\n")
    with pytest.raises(ScenarioError, match="ended with status 2"):
        regenerate(study, folder, tmp_path, lambda argv: 2)
    assert (folder / "demo_page.md").read_text() == "kept\n"


def test_unregistered_and_unrecorded_pages_are_reported(tmp_path, capsys):
    folder = _registry(tmp_path)
    (folder / "demo_page.md").write_text("# Demo\n")
    assert [s.status for s in check_pages(folder, tmp_path)] == [Status.UNRECORDED]
    with pytest.raises(SystemExit) as stop:
        main(["studies", "--check", "--folder", str(folder), "--root", str(tmp_path)])
    assert stop.value.code == 1 and "records no provenance" in capsys.readouterr().out
    (folder / "stray.md").write_text("# Stray\n")
    with pytest.raises(BadInputError, match="stray.md"):
        check_pages(folder, tmp_path)
    assert main(["studies", "--folder", str(tmp_path / "nowhere")]) == 2
