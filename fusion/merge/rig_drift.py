"""Does every camera stay where the calibration puts it? Each camera's disagreement with the other cameras
over time, and the stretch where a camera that moved during the session (bumped, turned) disagrees.

Two cameras' disagreement at one frame is the median, over the joints both track (neither seeing the
person's back), of the distance between their joints; per window of ``window_s`` seconds its median. A
camera's disagreement in a window is that with the other camera it agrees with best (so a steady camera
of a rig with one moved camera is not blamed; with two cameras both are). A camera has moved when a run
of at least ``min_windows`` windows lies above both ``threshold_m`` and ``ratio`` times its baseline
(its best window: a camera that moves keeps a good part).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from fusion.errors import BadInputError
from fusion.merge.views import CameraViews
from fusion.topology import TrackingState


@dataclass(frozen=True, eq=False)
class CameraDrift:
    """One camera's disagreement with the others.

    Attributes
    ----------
    name : the camera.
    disagreement_m : (W,) median disagreement per window [m]; NaN where nothing was compared.
    baseline_m : its smallest window value [m].
    moved : (start, end) reference-clock times [s] of the longest run of windows above the limits, or None.
    """

    name: str
    disagreement_m: np.ndarray
    baseline_m: float
    moved: tuple[float, float] | None

    def during_move_m(self, starts: np.ndarray) -> float:
        """Median disagreement [m] over the windows of the move (NaN without one)."""
        if self.moved is None:
            return float("nan")
        inside = (starts >= self.moved[0]) & (starts < self.moved[1])
        return float(np.nanmedian(self.disagreement_m[inside]))


@dataclass(frozen=True, eq=False)
class RigDrift:
    """Every camera's :class:`CameraDrift` on common windows starting at ``window_starts_s`` (W,) [s]."""

    window_starts_s: np.ndarray
    window_s: float
    cameras: tuple[CameraDrift, ...]

    @property
    def moved(self) -> tuple[CameraDrift, ...]:
        """The cameras that moved."""
        return tuple(c for c in self.cameras if c.moved is not None)

    def describe(self) -> str:
        """One line per camera that moved: when, and by how much it disagrees before and during the move."""
        if len(self.cameras) == 2 and len(self.moved) == 2:
            c = self.cameras[0]
            return (f"{c.name} and {self.cameras[1].name} disagree by {c.during_move_m(self.window_starts_s) * 1e3:.0f} mm "
                    f"from {c.moved[0]:.0f} s to {c.moved[1]:.0f} s (otherwise {c.baseline_m * 1e3:.0f} mm): one of "
                    "them moved")
        return "; ".join(f"{c.name} disagrees with the other cameras by {c.during_move_m(self.window_starts_s) * 1e3:.0f} mm "
                         f"from {c.moved[0]:.0f} s to {c.moved[1]:.0f} s (otherwise {c.baseline_m * 1e3:.0f} mm)"
                         for c in self.moved)


def _longest_run(flags: np.ndarray) -> tuple[int, int]:
    """(start, stop) indices of the longest run of True in ``flags`` (stop exclusive); (0, 0) when none."""
    best, start = (0, 0), None
    for i, f in enumerate(np.append(flags, False)):
        if f and start is None:
            start = i
        elif not f and start is not None:
            if i - start > best[1] - best[0]:
                best = (start, i)
            start = None
    return best


def rig_drift(views: CameraViews, *, window_s: float = 5.0, threshold_m: float = 0.15, ratio: float = 3.0,
              min_windows: int = 2) -> RigDrift:
    """Each camera's disagreement with the others per window, and whether it moved (module docstring).

    Parameters
    ----------
    views : two or more cameras' skeletons in the world frame of one calibration.
    window_s : window length [s]; a session shorter than six windows uses six windows (of at least 1 s).
    threshold_m, ratio : a window counts as moved above both ``threshold_m`` [m] and ``ratio`` x baseline.
    min_windows : windows in a row that make a move.
    """
    if len(views.names) < 2:
        raise BadInputError("rig_drift compares cameras with each other: it needs at least two")
    if not (window_s > 0 and threshold_m > 0 and ratio >= 1 and min_windows >= 1):
        raise BadInputError("need window_s > 0, threshold_m > 0, ratio >= 1 and min_windows >= 1")
    ok = (views.states == TrackingState.TRACKED) & ~views.back_facing[:, :, None]  # (C, T, J)
    pos = np.where(ok[..., None], views.positions, np.nan)
    t0 = views.times[0]
    window_s = max(1.0, min(window_s, (views.times[-1] - t0) / 6))
    starts = t0 + window_s * np.arange(max(1, int(np.ceil((views.times[-1] - t0) / window_s))))
    window = np.minimum(((views.times - t0) // window_s).astype(int), starts.size - 1)
    C = len(views.names)
    pair = np.full((C, C, starts.size), np.nan)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN slices: nothing compared there
        for a in range(C):
            for b in range(a + 1, C):
                per_frame = np.nanmedian(np.linalg.norm(pos[a] - pos[b], axis=-1), axis=1)  # (T,)
                pair[a, b] = pair[b, a] = [np.nanmedian(per_frame[window == w]) for w in range(starts.size)]
        cameras = []
        for c, name in enumerate(views.names):
            values = np.nanmin(np.delete(pair[c], c, axis=0), axis=0)  # (W,) best agreement with another camera
            baseline = float(np.nanmin(values)) if np.isfinite(values).any() else float("nan")
            high = np.isfinite(values) & (values > max(threshold_m, ratio * baseline))
            a, b = _longest_run(high)
            moved = (float(starts[a]), float(starts[b - 1] + window_s)) if b - a >= min_windows else None
            cameras.append(CameraDrift(name, values, baseline, moved))
    return RigDrift(starts, window_s, tuple(cameras))
