"""Time and space alignment of two recordings of one episode made by different systems.

Two systems that recorded the same repetition (e.g. UI-PRMD's Kinect v2 at 30 Hz and its Vicon at
100 Hz) were started and cut separately: their clocks differ by an unknown shift and their spaces by
an unknown rigid transform. :func:`align_episodes` finds both:

1. **time**: the moving arm's humerothoracic elevation (:func:`fusion.merge.angles.joint_angles`:
   it does not depend on either system's frame) is resampled on a common clock of ``rate_hz``, and
   the shift that maximises the Pearson correlation of the two traces over their overlap, within
   ``+-max_shift_s`` and with at least ``min_overlap`` of the shorter trace overlapping, is refined to
   a fraction of a sample by a parabola through the peak (:func:`estimate_shift`);
2. **space**: the corresponding joints (shoulders, elbows, wrists, spine-shoulder) of the Kinect
   frames that fall inside the optical recording's time span, against the optical joints
   interpolated at the shifted times, give ``T_vicon_kinect`` by Kabsch
   (:func:`fusion.calibrate.kabsch.kabsch`). The residual is the RMS distance of the mapped joints:
   it holds both systems' disagreement on where the joints are, not only noise.

Files without timestamps (UI-PRMD's) get times from a nominal rate; where a system dropped frames or
ran at another rate than the nominal one, the two clocks also run at different rates.
``rate_ratios`` lets :func:`align_episodes` search the ratio too (the best correlation over the
candidates); by default only the shift is searched. The ratio is only
well determined when both recordings cover the whole motion: where one starts or ends part-way
through it, stretching the other trace keeps raising the correlation, and the ratio found runs to
the end of the candidates (check it against them).

Convention: a Kinect sample at time ``t`` on its own clock is the moment ``rate_ratio * t + shift_s``
of the optical clock.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fusion.arrays import check_times, frozen
from fusion.calibrate.kabsch import kabsch_batch
from fusion.errors import BadInputError
from fusion.merge.angles import joint_angles
from fusion.skeleton import SkeletonStream
from fusion.topology import Landmark
from fusion.transforms import apply

ALIGNMENT_LANDMARKS = (Landmark.SPINE_SHOULDER, Landmark.SHOULDER_LEFT, Landmark.SHOULDER_RIGHT,
                       Landmark.ELBOW_LEFT, Landmark.ELBOW_RIGHT, Landmark.WRIST_LEFT, Landmark.WRIST_RIGHT)
"""Joints whose correspondences give the rigid transform."""


def resample(times: np.ndarray, values: np.ndarray, new_times: np.ndarray) -> np.ndarray:
    """Linear interpolation of (T, ...) ``values`` at times (T,) [s] onto (N,) ``new_times`` [s].

    Returns (N, ...); NaN outside ``[times[0], times[-1]]`` and where a neighbour that carries weight is NaN.
    """
    t = check_times(times)
    v = np.asarray(values, dtype=float)
    q = np.asarray(new_times, dtype=float)
    if v.shape[0] != t.size:
        raise BadInputError(f"values must have {t.size} rows (one per time), got shape {v.shape}")
    i = np.clip(np.searchsorted(t, q, side="right") - 1, 0, max(t.size - 2, 0))
    j = np.minimum(i + 1, t.size - 1)
    span = np.where(j > i, t[j] - t[i], 1.0)
    w = ((q - t[i]) / span).reshape((-1,) + (1,) * (v.ndim - 1))
    with np.errstate(invalid="ignore"):
        out = np.where(w == 0.0, v[i], np.where(w == 1.0, v[j], (1.0 - w) * v[i] + w * v[j]))
    inside = (q >= t[0]) & (q <= t[-1])
    out[~inside] = np.nan
    return out


def estimate_shift(times_a: np.ndarray, signal_a: np.ndarray, times_b: np.ndarray, signal_b: np.ndarray, *,
                   max_shift_s: float = 1.0, rate_hz: float = 100.0, min_overlap: float = 0.5
                   ) -> tuple[float, float, float]:
    """The shift [s] such that ``signal_b(t)`` best matches ``signal_a(t + shift)`` (module docstring).

    Parameters
    ----------
    times_a, signal_a : (Ta,) [s] and (Ta,) samples of the first signal (NaN where unknown).
    times_b, signal_b : (Tb,) [s] and (Tb,) samples of the second.
    max_shift_s : the shift is searched in ``[-max_shift_s, max_shift_s]`` [s].
    rate_hz : rate of the common clock [Hz].
    min_overlap : smallest fraction of the shorter signal's duration that must overlap.

    Returns
    -------
    shift_s : float, NaN when no shift gives enough overlap.
    correlation : float, Pearson correlation at the best grid shift.
    overlap_s : float, overlap [s] at the returned shift.

    Raises
    ------
    BadInputError
        Bad shapes, times not increasing, or non-positive parameters.
    """
    if not (max_shift_s > 0 and rate_hz > 0 and 0 < min_overlap <= 1):
        raise BadInputError("max_shift_s and rate_hz must be positive and min_overlap in (0, 1]")
    ta, tb = check_times(times_a), check_times(times_b)
    sa, sb = np.asarray(signal_a, dtype=float), np.asarray(signal_b, dtype=float)
    if sa.shape != ta.shape or sb.shape != tb.shape:
        raise BadInputError(f"signals must match their times: {sa.shape} vs {ta.shape}, {sb.shape} vs {tb.shape}")
    dt = 1.0 / rate_hz
    grid_b = tb[0] + dt * np.arange(int(np.floor((tb[-1] - tb[0]) / dt)) + 1)
    vb = resample(tb, sb, grid_b)
    need = min_overlap * min(ta[-1] - ta[0], tb[-1] - tb[0])
    shifts = dt * np.arange(-int(np.floor(max_shift_s / dt)), int(np.floor(max_shift_s / dt)) + 1)
    scores = np.full(shifts.size, np.nan)
    for k, s in enumerate(shifts):
        va = resample(ta, sa, grid_b + s)
        ok = np.isfinite(va) & np.isfinite(vb)
        if ok.sum() < 3 or (ok.sum() - 1) * dt < need:
            continue
        x, y = va[ok] - va[ok].mean(), vb[ok] - vb[ok].mean()
        denom = np.sqrt((x * x).sum() * (y * y).sum())
        scores[k] = (x * y).sum() / denom if denom > 0 else np.nan
    if not np.isfinite(scores).any():
        return float("nan"), float("nan"), 0.0
    k = int(np.nanargmax(scores))
    shift = shifts[k]
    if 0 < k < shifts.size - 1 and np.isfinite(scores[k - 1]) and np.isfinite(scores[k + 1]):
        c = scores[k - 1] - 2 * scores[k] + scores[k + 1]
        if c < 0:
            shift += dt * 0.5 * (scores[k - 1] - scores[k + 1]) / c
    overlap = max(0.0, min(ta[-1], tb[-1] + shift) - max(ta[0], tb[0] + shift))
    return float(shift), float(scores[k]), float(overlap)


@dataclass(frozen=True, eq=False)
class EpisodeAlignment:
    """Time shift and rigid transform between two recordings of one episode (module docstring).

    Attributes
    ----------
    shift_s : [s] a Kinect sample at ``t`` is the moment ``rate_ratio * t + shift_s`` of the optical
        clock; NaN if not found.
    rate_ratio : the ratio of the clocks' rates found (1 unless other candidates were given).
    correlation : Pearson correlation of the motion signals at the shift.
    T_vicon_kinect : (4, 4) rigid transform, ``p_vicon = T_vicon_kinect @ p_kinect``; the identity when
        ``ok`` is False.
    residual_rms_m : [m] RMS distance of the mapped corresponding joints; NaN when ``ok`` is False.
    overlap_s : [s] duration both recordings cover after the shift.
    n_frames : Kinect frames that entered the rigid fit.
    side : the moving arm whose elevation aligned the clocks (``left``/``right``).
    ok : False when the shift or the transform could not be found (too little overlap, too few
        corresponding joints).
    """

    shift_s: float
    rate_ratio: float
    correlation: float
    T_vicon_kinect: np.ndarray
    residual_rms_m: float
    overlap_s: float
    n_frames: int
    side: str
    ok: bool

    def __post_init__(self) -> None:
        T = np.array(self.T_vicon_kinect, dtype=float)
        if T.shape != (4, 4):
            raise BadInputError(f"T_vicon_kinect must be (4, 4), got {T.shape}")
        object.__setattr__(self, "T_vicon_kinect", frozen(T))


def moving_side(elevation_left: np.ndarray, elevation_right: np.ndarray) -> str:
    """``left`` or ``right``: the arm whose (T,) elevation [deg] has the larger range (NaN ignored)."""
    def rng(x: np.ndarray) -> float:
        x = x[np.isfinite(x)]
        return float(x.max() - x.min()) if x.size else -1.0
    return "left" if rng(np.asarray(elevation_left)) > rng(np.asarray(elevation_right)) else "right"


def _landmarks(stream: SkeletonStream) -> np.ndarray:
    idx = [stream.topology.index(lm) for lm in ALIGNMENT_LANDMARKS]
    return stream.positions[:, idx]


def align_episodes(vicon: SkeletonStream, kinect: SkeletonStream, *, max_shift_s: float = 1.0, rate_hz: float = 100.0,
                   min_overlap: float = 0.5, side: str | None = None,
                   rate_ratios: tuple[float, ...] | np.ndarray = (1.0,)) -> EpisodeAlignment:
    """Align a Kinect episode to the optical reference of the same episode in time and space
    (module docstring).

    Parameters
    ----------
    vicon : the optical reference's skeleton stream
        (:func:`~fusion.merge.marker_reference.reference_skeleton`), in the optical system's frame.
    kinect : the Kinect stream, in its camera's frame. Both may be of any topology with the
        landmarks of :data:`ALIGNMENT_LANDMARKS`, each on its own clock [s], positions [m].
    max_shift_s, rate_hz, min_overlap : see :func:`estimate_shift`.
    side : the moving arm, or None to take the arm with the larger elevation range in ``vicon``.
    rate_ratios : candidate ratios of the optical clock's rate to the Kinect's (module docstring).

    Returns
    -------
    EpisodeAlignment
        ``T_vicon_kinect`` such that ``p_vicon = T_vicon_kinect @ p_kinect``; ``ok`` False (not an
        exception) when it fails.

    Raises
    ------
    BadInputError
        ``side`` is not ``left``, ``right`` or None, a rate ratio is not positive, or bad parameters.
    """
    if side not in (None, "left", "right"):
        raise BadInputError(f"side must be 'left', 'right' or None, got {side!r}")
    ratios = np.atleast_1d(np.asarray(rate_ratios, dtype=float))
    if ratios.ndim != 1 or ratios.size == 0 or not np.all(np.isfinite(ratios) & (ratios > 0)):
        raise BadInputError(f"rate_ratios must be positive finite numbers, got {rate_ratios!r}")
    angles_a = joint_angles(vicon.positions, vicon.topology)
    angles_b = joint_angles(kinect.positions, kinect.topology)
    if side is None:
        side = moving_side(angles_a["ht_elevation_left"], angles_a["ht_elevation_right"])
    name = f"ht_elevation_{side}"
    shift, ratio, corr, overlap = float("nan"), float(ratios[0]), float("nan"), 0.0
    for r in ratios:
        found = estimate_shift(vicon.timestamps, angles_a[name], r * kinect.timestamps, angles_b[name],
                               max_shift_s=max_shift_s, rate_hz=rate_hz, min_overlap=min_overlap)
        if np.isfinite(found[1]) and (not np.isfinite(corr) or found[1] > corr):
            (shift, corr, overlap), ratio = found, float(r)
    failed = EpisodeAlignment(shift, ratio, corr, np.eye(4), float("nan"), overlap, 0, side, False)
    if not np.isfinite(shift):
        return failed
    p_a = resample(vicon.timestamps, _landmarks(vicon), ratio * kinect.timestamps + shift)
    p_b = _landmarks(kinect)
    finite = np.isfinite(p_a).all(axis=-1) & np.isfinite(p_b).all(axis=-1)
    frames = finite.any(axis=1)
    if finite.sum() < 3:
        return failed
    pts_a, pts_b, w = p_a[finite], p_b[finite], np.ones(int(finite.sum()))
    T_vicon_kinect, ok = kabsch_batch(pts_b, pts_a, w)
    if not ok:
        return failed
    residual = float(np.sqrt(np.mean(np.sum((apply(T_vicon_kinect, pts_b) - pts_a) ** 2, axis=-1))))
    return EpisodeAlignment(shift, ratio, corr, T_vicon_kinect, residual, overlap, int(frames.sum()), side, True)
