"""Signed errors of a Kinect episode's clinical angles against an optical reference of the same episode.

Per episode (one repetition of an arm movement), for the moving arm (the one an
:class:`~fusion.merge.episode_alignment.EpisodeAlignment` names), Kinect minus reference, in degrees:

- ``peak_elevation``: the largest humerothoracic elevation of each trace (a per-repetition value,
  found on each system's own clock, so it does not depend on the time alignment), read from the
  traces after a running median of :data:`PEAK_MEDIAN_S` (so a one- or two-frame tracking glitch is
  not read as the repetition's peak);
- ``elbow_flexion_at_peak`` and ``plane_of_elevation_at_peak``: those angles at each system's own
  peak frame;
- ``elevation_rmse``: the RMS difference of the elevation traces over the aligned overlap (the
  reference interpolated at the Kinect's times mapped by the alignment's clock ratio and shift); NaN
  when the alignment failed;
- ``peak_elevation_thorax_part``: how much of the peak elevation error the thorax axis makes: at the
  Kinect's peak frame, its elevation minus its elevation with its trunk joints (:data:`TRUNK_JOINTS`,
  which place the thorax frame's axis) replaced by the reference's at the aligned time (read from the
  same running medians); the rest of the error is the arm's. NaN when the alignment failed.

Both streams go through :func:`fusion.merge.angles.joint_angles`, the Kinect's mapped into the
reference's z-up frame by the alignment's ``T_vicon_kinect`` (the arm angles do not depend on it).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from fusion.arrays import frozen
from fusion.errors import BadInputError
from fusion.merge.angles import joint_angles
from fusion.merge.episode_alignment import EpisodeAlignment, resample
from fusion.skeleton import SkeletonStream
from fusion.topology import Landmark
from fusion.transforms import apply

PEAK_VALUES = ("peak_elevation", "elbow_flexion_at_peak", "plane_of_elevation_at_peak")
"""The per-repetition values compared, in order."""

TRUNK_JOINTS = (Landmark.PELVIS, Landmark.SPINE_MID, Landmark.SPINE_SHOULDER)
"""The joints that place the thorax frame's up axis (:func:`fusion.facing.trunk_axes`)."""

PEAK_MEDIAN_S = 0.15
"""Window [s] of the running median the peak values are read from (5 frames at 30 Hz)."""


def running_median(values: np.ndarray, times: np.ndarray, window_s: float = PEAK_MEDIAN_S) -> np.ndarray:
    """(T,) the NaN-ignoring running median of ``values`` (T,) over an odd number of frames spanning
    about ``window_s`` at the median frame interval of ``times`` (T,) [s]; the ends use what they have."""
    values = np.asarray(values, dtype=float)
    if values.size < 3:
        return values.copy()
    half = max(int(round(window_s / float(np.median(np.diff(times))) / 2)), 0)
    if half == 0:
        return values.copy()
    padded = np.pad(values, half, constant_values=np.nan)
    windows = np.lib.stride_tricks.sliding_window_view(padded, 2 * half + 1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN windows stay NaN
        return np.nanmedian(windows, axis=-1)


@dataclass(frozen=True, eq=False)
class EpisodeAngleErrors:
    """The Kinect's angle errors of one episode against the reference (module docstring).

    Attributes
    ----------
    side : the moving arm (``left``/``right``).
    kinect_deg : (3,) [deg] the Kinect's :data:`PEAK_VALUES`; NaN where undefined.
    reference_deg : (3,) [deg] the reference's.
    elevation_rmse_deg : [deg] RMS difference of the elevation traces over the aligned overlap; NaN
        when the alignment failed or nothing overlaps.
    n_compared : Kinect frames in that RMS.
    thorax_part_deg : [deg] the thorax axis's part of the peak elevation error (module docstring);
        NaN when unknown.
    """

    side: str
    kinect_deg: np.ndarray
    reference_deg: np.ndarray
    elevation_rmse_deg: float
    n_compared: int
    thorax_part_deg: float = float("nan")

    def __post_init__(self) -> None:
        if self.side not in ("left", "right"):
            raise BadInputError(f"side must be 'left' or 'right', got {self.side!r}")
        for name in ("kinect_deg", "reference_deg"):
            arr = np.array(getattr(self, name), dtype=float)
            if arr.shape != (len(PEAK_VALUES),):
                raise BadInputError(f"{name} must have shape ({len(PEAK_VALUES)},), got {arr.shape}")
            object.__setattr__(self, name, frozen(arr))

    @property
    def errors_deg(self) -> np.ndarray:
        """(3,) [deg] Kinect minus reference of :data:`PEAK_VALUES`."""
        return self.kinect_deg - self.reference_deg

    def as_dict(self) -> dict[str, float]:
        """Error name -> signed error [deg] (the three peak values, ``elevation_rmse`` and
        ``peak_elevation_thorax_part``)."""
        return {**{n: float(e) for n, e in zip(PEAK_VALUES, self.errors_deg)},
                "elevation_rmse": self.elevation_rmse_deg, "peak_elevation_thorax_part": self.thorax_part_deg}


def _peak_frame(elevation: np.ndarray) -> int | None:
    """The frame of the largest (running-median) elevation; None when there is none."""
    return int(np.nanargmax(elevation)) if np.isfinite(elevation).any() else None


def _peak_values(angles: dict[str, np.ndarray], side: str, times: np.ndarray) -> np.ndarray:
    traces = [running_median(angles[f"{name}_{side}"], times)
              for name in ("ht_elevation", "elbow_flexion", "ht_plane_of_elevation")]
    k = _peak_frame(traces[0])
    return np.full(3, np.nan) if k is None else np.array([t[k] for t in traces])


def _thorax_part(vicon: SkeletonStream, kinect: SkeletonStream, seen: np.ndarray, elevation: np.ndarray,
                 ref_times: np.ndarray, side: str) -> float:
    """The thorax axis's part of the peak elevation error (module docstring); ``seen`` (T, J, 3) [m] the
    Kinect's joints in the reference's frame, ``elevation`` (T,) [deg] their elevation of ``side``,
    ``ref_times`` (T,) [s] its frames on the reference's clock."""
    hybrid = seen.copy()
    for lm in (lm for lm in TRUNK_JOINTS if lm in kinect.topology.landmarks and lm in vicon.topology.landmarks):
        hybrid[:, kinect.topology.index(lm)] = resample(vicon.timestamps, vicon.positions[:, vicon.topology.index(lm)],
                                                        ref_times)
    own = running_median(elevation, kinect.timestamps)
    k = _peak_frame(own)
    if k is None:
        return float("nan")
    with_reference = joint_angles(hybrid, kinect.topology).as_dict()[f"ht_elevation_{side}"]
    return float(own[k] - running_median(with_reference, kinect.timestamps)[k])


def episode_angle_errors(vicon: SkeletonStream, kinect: SkeletonStream, alignment: EpisodeAlignment
                         ) -> EpisodeAngleErrors:
    """Kinect-minus-reference errors of one episode (module docstring).

    Parameters
    ----------
    vicon : the reference's skeleton stream in its z-up frame [m], on its clock [s].
    kinect : the Kinect's stream in its camera frame [m], on its clock [s].
    alignment : :func:`~fusion.merge.episode_alignment.align_episodes` of the two; its ``side`` is
        the arm compared.

    Returns
    -------
    EpisodeAngleErrors
    """
    side = alignment.side
    ref = joint_angles(vicon.positions, vicon.topology).as_dict()
    seen = apply(alignment.T_vicon_kinect, kinect.positions)
    kin = joint_angles(seen, kinect.topology).as_dict()
    rmse, n, thorax = float("nan"), 0, float("nan")
    if alignment.ok and np.isfinite(alignment.shift_s):
        name = f"ht_elevation_{side}"
        ref_times = alignment.rate_ratio * kinect.timestamps + alignment.shift_s
        d = kin[name] - resample(vicon.timestamps, ref[name], ref_times)
        d = d[np.isfinite(d)]
        n = int(d.size)
        rmse = float(np.sqrt(np.mean(d ** 2))) if n else float("nan")
        thorax = _thorax_part(vicon, kinect, seen, kin[name], ref_times, side)
    return EpisodeAngleErrors(side, _peak_values(kin, side, kinect.timestamps), _peak_values(ref, side, vicon.timestamps),
                              rmse, n, thorax)
