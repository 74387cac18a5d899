"""How well the humanoid fits recorded motion: several sources retargeted, one table.

:func:`fit_sources` retargets each source as ``mocap-bench retarget`` does (format from the name,
default options: a fused directory in its world frame, the only camera of a one-camera recording
turned upright, C3D / TRC / BVH through their default marker maps) and keeps, per source, the
fitted subject and the landmark residuals per joint group (:meth:`sim.retarget.RetargetResult.group_errors`).
:func:`report_markdown` writes them as one Markdown table (``mocap-bench retarget-report``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scenarios.replay_source import guess_format, load_trajectory
from sim.replay import fit_motion
from sim.retarget import RetargetOptions
from sim.retarget_scale import ScaleEstimate

GROUPS = ("trunk", "left arm", "right arm", "left leg", "right leg")
"""Joint groups of the table, in column order."""


@dataclass(frozen=True)
class SourceFit:
    """One source's retargeting, summarised.

    Attributes
    ----------
    source : the path given.
    frames : number of frames fitted.
    failed : frames that did not converge.
    scale : the fitted subject (stature, multipliers, measured segment lengths).
    residuals_m : group -> (median, 90th percentile) landmark residual [m]; groups without a
        landmark left out.
    """

    source: str
    frames: int
    failed: int
    scale: ScaleEstimate
    residuals_m: dict[str, tuple[float, float]]


def fit_sources(sources: Sequence[Path], options: RetargetOptions = RetargetOptions(), *,
                progress: Callable[[int], None] | None = None) -> list[SourceFit]:
    """Retarget every source and summarise each fit.

    Parameters
    ----------
    sources : recording / run / fused directories, or C3D, TRC, BVH files.
    options : how to retarget.
    progress : called with the number of frames fitted since the last call.

    Returns
    -------
    list of SourceFit, in the order of ``sources``.

    Raises
    ------
    BadInputError
        A source that cannot be read or fitted (named by its path).
    """
    fits = []
    for source in sources:
        trajectory = load_trajectory(source, guess_format(source))
        _, result, scale = fit_motion(trajectory, options, progress=progress)
        residuals = {g: (float(np.median(e)), float(np.percentile(e, 90))) for g, e in result.group_errors().items()}
        fits.append(SourceFit(str(source), int(result.times.size), int(result.failed_frames.size), scale, residuals))
    return fits


def report_markdown(fits: Sequence[SourceFit]) -> str:
    """The fits as a Markdown table: residual median (90th percentile) per joint group [mm], frames,
    frames not converged, stature [m] and segment multipliers."""
    head = ["source", "frames", "not converged", "stature [m]", "trunk / upper arm / forearm / thigh / shank",
            *(f"{g} [mm]" for g in GROUPS)]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for f in fits:
        a = f.scale.anthropometry
        cells = [f.source, str(f.frames), str(f.failed), f"{f.scale.stature_m:.3f}",
                 " / ".join(f"{m:.2f}" for m in (a.trunk, a.upper_arm, a.forearm, a.thigh, a.shank))]
        cells += [f"{1e3 * f.residuals_m[g][0]:.1f} ({1e3 * f.residuals_m[g][1]:.1f})" if g in f.residuals_m else "-"
                  for g in GROUPS]
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "Residual: distance of a humanoid landmark from its target, median (90th percentile) over the "
              "frames and joints of the group. Stature: standing height of the scaled humanoid."]
    return "\n".join(lines) + "\n"
