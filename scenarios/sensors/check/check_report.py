"""Running the whole sensor check, and its report: Markdown, JSON and PNG plots.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from pathlib import Path
from types import MappingProxyType

import numpy as np

from fusion.errors import BadInputError
from fusion.io.atomic import atomic_directory, write_text_atomic
from fusion.topology import KINECT_V2
from scenarios.runner import VERSION
from scenarios.sensors.check.check_results import SECTION_TITLES, Section, SensorCheck
from scenarios.sensors.check.clocks import check_clocks
from scenarios.sensors.check.depth_checks import (
    CAMERA,
    NOISE_REL_TOL,
    check_depth_noise,
    check_projection,
)
from scenarios.sensors.check.tracker_checks import (
    BONES,
    check_back_facing,
    check_bone_lengths,
    check_occlusion,
)
from scenarios.show import plt, save_figure
from sim.anthropometry import Anthropometry
from sim.camera_clock import ClockModel
from sim.depth_noise import DepthNoise, sigma_axial_mm
from sim.humanoid_model import build_humanoid
from sim.sensor_profile import SensorProfile
from sim.tracker_noise import TrackerNoise

REPORT_NAME = "sensor_check.md"


RESULT_NAME = "sensor_check.json"


def run_sensor_check(seed: int = 0, *, profile: SensorProfile | None = None,
                     progress: Callable[[int, int, str], None] | None = None) -> SensorCheck:
    """Run every section of the sensor check.

    Parameters
    ----------
    seed : int
        Seed of everything random, >= 0; split with ``SeedSequence.spawn`` into one stream per section.
    profile : SensorProfile or None
        Sensor models to check (tracker, depth, clock); None checks the models with the published
        defaults of ``reference/sensors.md`` (the ranges the checks derive their expectations from).
    progress : callable or None
        Called as ``progress(i, n, title)`` before section ``i`` of ``n`` (1-based) starts.

    Returns
    -------
    SensorCheck
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise BadInputError(f"seed must be an integer >= 0, got {seed!r}")
    rngs = [np.random.default_rng(s) for s in np.random.SeedSequence(int(seed)).spawn(len(SECTION_TITLES))]
    humanoid = build_humanoid(Anthropometry())
    tracker = TrackerNoise() if profile is None else profile.tracker
    depth = DepthNoise() if profile is None else profile.depth
    clock = ClockModel() if profile is None else profile.clock
    steps: dict[str, Callable[[np.random.Generator], Section]] = {
        "projection": lambda rng: check_projection(rng=rng),
        "depth_noise": lambda rng: check_depth_noise(rng=rng, noise=depth),
        "back_facing": lambda rng: check_back_facing(humanoid, rng=rng, noise=tracker),
        "occlusion": lambda rng: check_occlusion(humanoid, rng=rng, noise=tracker),
        "bone_lengths": lambda rng: check_bone_lengths(humanoid, rng=rng, noise=tracker),
        "clocks": lambda rng: check_clocks(rng=rng, model=clock),
    }
    sections = []
    for i, ((key, title), rng) in enumerate(zip(SECTION_TITLES.items(), rngs), start=1):
        if progress is not None:
            progress(i, len(SECTION_TITLES), title)
        sections.append(steps[key](rng))
    return SensorCheck(int(seed), tuple(sections))


def _number(value: float | None) -> str:
    return "" if value is None else f"{value:.5g}"


def _rows(section: Section) -> list[list[str]]:
    """Header and one row of cells per check."""
    rows = [["case", "quantity", "measured", "expected", "accepted", "tolerance", "pass", "notes"]]
    for c in section.checks:
        notes = "; ".join(f"{k} {v:.4g}" for k, v in c.extra.items())
        rows.append([c.case, c.quantity, f"{_number(c.measured)} {c.unit}", _number(c.expected),
                     f"{_number(c.low)} - {_number(c.high)}", c.tolerance, "pass" if c.passed else "FAIL", notes])
    return rows


def format_summary(result: SensorCheck) -> str:
    """Plain-text tables of every check, one block per section, for a terminal."""
    lines = [f"sensor check, seed {result.seed}: {sum(c.passed for c in result.checks)} of {len(result.checks)} "
             f"checks pass"]
    for k, section in enumerate(result.sections, start=1):
        rows = [r[:7] for r in _rows(section)]
        widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
        lines += ["", f"{k}. {section.title}"]
        lines += ["  ".join(cell.ljust(w) for cell, w in zip(r, widths)).rstrip() for r in rows]
    return "\n".join(lines)


def format_report(result: SensorCheck, figures: Mapping[str, str]) -> str:
    """The Markdown report; ``figures`` maps a section key to its PNG file name."""
    n_pass = sum(c.passed for c in result.checks)
    lines = ["# Sensor check", "",
             f"Seed {result.seed}, mocap-bench {VERSION}. **{n_pass} of {len(result.checks)} checks pass.** "
             "The simulated sensors measured against the facts they model (`reference/sensors.md`) and closed forms.",
             "", "| section | checks | passed |", "| --- | --- | --- |"]
    lines += [f"| {k}. {s.title} | {len(s.checks)} | {sum(c.passed for c in s.checks)} |"
              for k, s in enumerate(result.sections, start=1)]
    for k, section in enumerate(result.sections, start=1):
        rows = _rows(section)
        lines += ["", f"## {k}. {section.title}", "", section.method, ""]
        lines += ["| " + " | ".join(rows[0]) + " |", "|" + " --- |" * len(rows[0])]
        lines += ["| " + " | ".join(r) + " |" for r in rows[1:]]
        if section.key in figures:
            lines += ["", f"![{section.title}]({figures[section.key]})"]
    return "\n".join(lines) + "\n"


def _plot_projection(arrays: Mapping[str, np.ndarray], path: Path) -> None:
    fig, ax = plt.subplots(figsize=(7, 6))
    im = ax.imshow(arrays["depth_mm"], cmap="viridis", interpolation="nearest")
    fig.colorbar(im, ax=ax, shrink=0.8, label="depth [mm]")
    ax.scatter(*arrays["expected_uv"].T, marker="+", s=120, color="red", label="image ellipse centre (closed form)")
    ax.scatter(*arrays["measured_uv"].T, marker="o", s=60, facecolor="none", edgecolor="white",
               label="silhouette centroid (rendered)")
    ax.set_xlim(-0.5, CAMERA.intrinsics.width - 0.5)
    ax.set_ylim(CAMERA.intrinsics.height - 0.5, -0.5)
    ax.set_xlabel("u [px]")
    ax.set_ylabel("v [px]")
    ax.set_title("Spheres rendered one at a time by an ideal camera (overlaid)", fontsize=10)
    ax.legend(loc="lower center", fontsize=8, facecolor="0.75")
    save_figure(fig, path)


def _plot_depth_noise(arrays: Mapping[str, np.ndarray], path: Path) -> None:
    walls = arrays["walls"]  # (distance, tilt, mean theta [deg], measured std, expected std)
    noise = DepthNoise()
    fig, (ax_z, ax_t) = plt.subplots(1, 2, figsize=(11, 4.2))
    z = np.linspace(0.5, 4.5, 200)
    theta = np.radians(np.linspace(0.0, 80.0, 200))
    for ax, x, sigma, sel, px, xlabel, title in (
        (ax_z, z, sigma_axial_mm(z, 0.0, noise), walls[:, 1] == 0, walls[:, 0], "depth z [m]", "head-on (theta = 0)"),
        (ax_t, np.degrees(theta), sigma_axial_mm(2.5, theta, noise), walls[:, 0] == 2.5, walls[:, 2],
         "incidence theta [deg]", "z = 2.5 m"),
    ):
        expected = np.sqrt(sigma**2 + 1 / 12)
        ax.plot(x, sigma, color="#90a4ae", lw=1, ls="--", label="sigma(z, theta), Fankhauser")
        ax.plot(x, expected, color="#1565c0", lw=1.5, label="with mm rounding: sqrt(sigma^2 + 1/12)")
        ax.fill_between(x, (1 - NOISE_REL_TOL) * expected, (1 + NOISE_REL_TOL) * expected, color="#1565c0",
                        alpha=0.12, label=f"+-{NOISE_REL_TOL:.0%}")
        ax.scatter(px[sel], walls[sel, 3], color="#c62828", zorder=3, label="measured (wall; window mean theta)")
        ax.set_xlabel(xlabel)
        ax.set_ylabel("depth std [mm]")
        ax.set_title(title, fontsize=10)
        ax.grid(alpha=0.3)
    ax_z.legend(fontsize=8)
    fig.suptitle("Depth noise: measured residual std against the model")
    save_figure(fig, path)


def _plot_bone_lengths(arrays: Mapping[str, np.ndarray], path: Path) -> None:
    t, sim, true = arrays["times"], arrays["simulated_m"], arrays["true_m"]
    fig, axes = plt.subplots(len(BONES), 1, figsize=(10, 7), sharex=True)
    for ax, (a, b, _), k in zip(axes, BONES, range(len(BONES))):
        ax.plot(t, 100 * sim[:, k], color="#1565c0", lw=0.8, label="simulated Kinect (1 camera)")
        ax.plot(t, 100 * true[:, k], color="#c62828", lw=1.5, label="true")
        ax.set_ylabel("length [cm]")
        name = f"{KINECT_V2.joints[KINECT_V2.index(a)]}-{KINECT_V2.joints[KINECT_V2.index(b)]}"
        ax.set_title(f"{name}: std {100 * np.nanstd(sim[:, k]):.2f} cm", fontsize=9)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8, loc="lower left")
    axes[-1].set_xlabel("session time [s] (salutes, then hand lifts, right arm)")
    save_figure(fig, path)


_PLOTS: Mapping[str, Callable[[Mapping[str, np.ndarray], Path], None]] = MappingProxyType({
    "projection": _plot_projection, "depth_noise": _plot_depth_noise, "bone_lengths": _plot_bone_lengths,
})


def write_sensor_check(result: SensorCheck, out_dir: str | Path) -> list[Path]:
    """Write ``sensor_check.md``, ``sensor_check.json`` and the figures (``<section key>.png``) into ``out_dir``.

    Returns the written paths, the report first.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    figures = {s.key: f"{s.key}.png" for s in result.sections if s.key in _PLOTS}
    written = [out_dir / REPORT_NAME, out_dir / RESULT_NAME]
    for section in result.sections:
        if section.key in figures:
            written.append(out_dir / figures[section.key])
            _PLOTS[section.key](section.arrays, written[-1])
    write_text_atomic(written[1], json.dumps(result.to_dict(), indent=2) + "\n")
    write_text_atomic(written[0], format_report(result, figures))
    return written


def sensor_check_to_disk(
    out_dir: str | Path, *, seed: int = 0, overwrite: bool = False, profile: SensorProfile | None = None,
    progress: Callable[[int, int, str], None] | None = None,
) -> tuple[SensorCheck, list[Path]]:
    """Run the sensor check and write it into ``out_dir`` atomically (see :func:`write_sensor_check`).

    Parameters
    ----------
    out_dir : the output directory; created, or replaced when ``overwrite``.
    seed : seed of every random draw, >= 0.
    overwrite : replace an existing non-empty ``out_dir``.
    profile : sensor models to check; None the published defaults (see :func:`run_sensor_check`).
    progress : called as ``progress(i, n, title)`` before each section.

    Returns
    -------
    result : SensorCheck
    written : list of Path, the files in ``out_dir``, the report first.

    Raises
    ------
    BadInputError
        ``out_dir`` exists and is not empty (and ``overwrite`` is False) or is a file, checked before
        anything runs; or a bad ``seed``.
    """
    out_dir = Path(out_dir)
    with atomic_directory(out_dir, overwrite=overwrite) as tmp:
        result = run_sensor_check(seed, profile=profile, progress=progress)
        written = write_sensor_check(result, tmp)
    return result, [out_dir / p.name for p in written]
