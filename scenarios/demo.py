"""``mocap-bench demo``: every stage on the default scenario, ending in a report with pictures."""

from __future__ import annotations

from pathlib import Path

from fusion.atomic import write_text_atomic
from scenarios.config import load_scenario
from scenarios.runner import load_run, simulate_to_disk
from scenarios.show import show_run


def run_demo(out: Path, *, scenario: str = "fma_2cam", seed: int | None = None,
             duration_s: float | None = None) -> Path:
    """Simulate ``scenario`` into ``out/run``, draw it into ``out/pictures`` and write ``out/README.md``.

    An existing demo output directory is replaced.
    """
    out = Path(out)
    sc = load_scenario(scenario)
    print(f"[1/2] simulating {sc.name}: {sc.description}", flush=True)
    run = simulate_to_disk(sc, out / "run", seed=seed, duration_s=duration_s, overwrite=True)
    recording, truth = load_run(run)
    print("[2/2] drawing the rig and each camera's view", flush=True)
    pictures = show_run(recording, truth, out / "pictures")
    lines = [f"# mocap-bench demo: {sc.name}", "", sc.description, "",
             f"Seed {recording.metadata['seed']}, {recording.metadata['duration_s']:.1f} s of session.", "",
             "| camera | skeleton frames | depth frames | tracked joints | inferred joints | flipped frames (truth) |",
             "| --- | --- | --- | --- | --- | --- |"]
    for cam, ct in zip(recording.cameras, truth.cameras):
        st = cam.skeleton.states
        lines.append(f"| {cam.name} | {cam.skeleton.n_frames} | {0 if cam.depth is None else cam.depth.n_frames} | "
                     f"{(st == 2).mean():.1%} | {(st == 1).mean():.1%} | {ct.flipped.mean():.1%} |")
    lines += ["", "## Pictures", ""] + [f"![{p.stem}](pictures/{p.name})" for p in pictures]
    write_text_atomic(out / "README.md", "\n".join(lines) + "\n")
    print(f"report: {out / 'README.md'}")
    return out / "README.md"
