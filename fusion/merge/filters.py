"""Temporal smoothing and bone-length consistency of a merged skeleton (beyond the paper).

- :func:`smooth` runs a constant-velocity Kalman filter (optionally with a Rauch-Tung-Striebel
  smoother) or a One-Euro filter over each joint. The Kalman filter trusts a measurement according
  to its merged :class:`~fusion.merge.methods.Reliability` and bridges short gaps by prediction.
- :func:`enforce_bone_lengths` gives every bone its median length over time, moving child joints
  along their bones from the root to the leaves.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

from fusion.arrays import nanmedian
from fusion.errors import BadInputError
from fusion.merge.methods import MergedSkeleton, Reliability
from fusion.topology import Topology


class TemporalFilter(enum.Enum):
    """Temporal filter of :func:`smooth`."""

    NONE = "none"
    KALMAN = "kalman"
    ONE_EURO = "one_euro"


def _check_positive(name: str, value: float) -> None:
    if not (np.isfinite(value) and value > 0):
        raise BadInputError(f"{name} must be positive and finite, got {value}")


@dataclass(frozen=True)
class KalmanParams:
    """Constant-velocity Kalman filter settings (the same model on x, y and z of every joint).

    Attributes
    ----------
    acceleration_psd : float
        Spectral density q [m^2/s^3] of the white-noise acceleration driving the model; larger
        follows fast motion more closely and smooths less.
    measurement_std_high_m, measurement_std_low_m, measurement_std_back_m : float
        Measurement noise std [m] of merged joints of reliability HIGH, LOW and BACK_POSE.
    initial_speed_std : float
        Prior std [m/s] of a joint's speed when a track starts.
    max_gap_s : float
        Gaps between measurements up to this long [s] are bridged by prediction; after a longer
        gap the track restarts and the gap stays NaN.
    smoother : bool
        Run the Rauch-Tung-Striebel backward pass (offline, uses future frames) after the forward
        filter.
    """

    acceleration_psd: float = 1.0
    measurement_std_high_m: float = 0.01
    measurement_std_low_m: float = 0.03
    measurement_std_back_m: float = 0.08
    initial_speed_std: float = 1.0
    max_gap_s: float = 0.3
    smoother: bool = True

    def __post_init__(self) -> None:
        for name in ("acceleration_psd", "measurement_std_high_m", "measurement_std_low_m",
                     "measurement_std_back_m", "initial_speed_std", "max_gap_s"):
            _check_positive(name, getattr(self, name))

    def measurement_variance(self) -> np.ndarray:
        """(4,) variance [m^2] per :class:`Reliability` value (NaN for NONE: no measurement)."""
        return np.array([np.nan, self.measurement_std_back_m, self.measurement_std_low_m,
                         self.measurement_std_high_m]) ** 2


@dataclass(frozen=True)
class OneEuroParams:
    """One-Euro filter settings (Casiez et al., CHI 2012), applied to 3-D joint positions.

    Attributes
    ----------
    min_cutoff_hz : float
        Cutoff frequency [Hz] at rest; lower removes more jitter and lags more.
    beta : float
        Cutoff increase [Hz per m/s] with the joint's filtered speed; higher lags less in motion.
    d_cutoff_hz : float
        Cutoff frequency [Hz] of the speed estimate.
    max_gap_s : float
        After a gap longer than this [s] the filter restarts. Gaps are not bridged (stay NaN).
    """

    min_cutoff_hz: float = 1.0
    beta: float = 10.0
    d_cutoff_hz: float = 1.0
    max_gap_s: float = 0.3

    def __post_init__(self) -> None:
        for name in ("min_cutoff_hz", "d_cutoff_hz", "max_gap_s"):
            _check_positive(name, getattr(self, name))
        if not (np.isfinite(self.beta) and self.beta >= 0):
            raise BadInputError(f"beta must be finite and >= 0, got {self.beta}")


def smooth(
    merged: MergedSkeleton,
    method: TemporalFilter,
    *,
    kalman: KalmanParams = KalmanParams(),
    one_euro: OneEuroParams = OneEuroParams(),
) -> MergedSkeleton:
    """Filter a merged skeleton over time, each joint on its own.

    Parameters
    ----------
    merged : MergedSkeleton
        T frames, J joints.
    method : TemporalFilter
        NONE returns ``merged`` itself.
    kalman, one_euro : KalmanParams, OneEuroParams
        Settings of the respective filter.

    Returns
    -------
    MergedSkeleton
        Filtered positions. Frames the Kalman filter bridged get reliability LOW with
        ``n_cameras`` 0 and ``source_camera`` -1; everything else keeps its reliability and sources.
    """
    if not isinstance(method, TemporalFilter):
        raise BadInputError(f"method must be a TemporalFilter ({', '.join(m.name for m in TemporalFilter)}), "
                            f"got {method!r}")
    if method is TemporalFilter.NONE:
        return merged
    if method is TemporalFilter.ONE_EURO:
        positions = _one_euro(merged.times, merged.positions, one_euro)
        return MergedSkeleton(merged.times, positions, merged.reliability, merged.n_cameras, merged.source_camera)
    positions, bridged = _kalman(merged, kalman)
    reliability = np.where(bridged, np.int8(Reliability.LOW), merged.reliability)
    return MergedSkeleton(merged.times, positions, reliability, merged.n_cameras, merged.source_camera)


def _gap_structure(times: np.ndarray, measured: np.ndarray, max_gap_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Track starts and bridgeable frames of (T, J) measurement masks.

    Returns ``(start, bridged)``, both (T, J) bool: ``start`` marks measurements with no earlier
    measurement within ``max_gap_s``; ``bridged`` marks unmeasured frames between two measurements
    at most ``max_gap_s`` apart.
    """
    T = times.size
    frame = np.arange(T)[:, None]
    prev = np.maximum.accumulate(np.where(measured, frame, -1), axis=0)
    nxt = np.minimum.accumulate(np.where(measured, frame, T)[::-1], axis=0)[::-1]
    prev_before = np.vstack([np.full((1, measured.shape[1]), -1), prev[:-1]])
    t_ext = np.append(times, np.inf)
    t_prev = np.where(prev_before >= 0, times[np.maximum(prev_before, 0)], -np.inf)
    start = measured & (times[:, None] - t_prev > max_gap_s)
    gap = np.where(prev >= 0, t_ext[nxt] - times[np.maximum(prev, 0)], np.inf)
    bridged = ~measured & (gap <= max_gap_s)
    return start, bridged


def _kalman(merged: MergedSkeleton, params: KalmanParams) -> tuple[np.ndarray, np.ndarray]:
    """(T, J, 3) filtered (or smoothed) positions, NaN outside tracks, and the (T, J) bridged mask."""
    times, z = merged.times, merged.positions
    T, J = z.shape[:2]
    measured = merged.reliability > Reliability.NONE
    if T == 0:
        return z.copy(), measured
    r = params.measurement_variance()[merged.reliability]
    start, bridged = _gap_structure(times, measured, params.max_gap_s)
    q = params.acceleration_psd
    dts = np.diff(times, prepend=times[0])
    x, v = np.zeros((J, 3)), np.zeros((J, 3))
    p11, p12, p22 = np.ones(J), np.zeros(J), np.ones(J)
    xf, vf = np.empty((T, J, 3)), np.empty((T, J, 3))
    pf = np.empty((T, 3, J))  # filtered covariance entries (11, 12, 22)
    pp = np.empty((T, 3, J))  # predicted covariance entries
    for t in range(T):
        dt = dts[t]
        x = x + dt * v
        p11, p12, p22 = (p11 + dt * (2 * p12 + dt * p22) + q * dt**3 / 3, p12 + dt * p22 + q * dt**2 / 2,
                         p22 + q * dt)
        pp[t] = (p11, p12, p22)
        upd = measured[t] & ~start[t]
        if upd.any():
            s = p11 + np.where(upd, r[t], 1.0)
            k1, k2 = np.where(upd, p11 / s, 0.0), np.where(upd, p12 / s, 0.0)
            innovation = np.where(upd[:, None], z[t] - x, 0.0)
            x, v = x + k1[:, None] * innovation, v + k2[:, None] * innovation
            p11, p12, p22 = (1 - k1) * p11, (1 - k1) * p12, p22 - k2 * p12
        new = start[t]
        if new.any():
            x = np.where(new[:, None], z[t], x)
            v = np.where(new[:, None], 0.0, v)
            p11 = np.where(new, r[t], p11)
            p12 = np.where(new, 0.0, p12)
            p22 = np.where(new, params.initial_speed_std**2, p22)
        xf[t], vf[t], pf[t] = x, v, (p11, p12, p22)
    if params.smoother:
        xf = _rts(xf, vf, pf, pp, dts, start)
    keep = measured | bridged
    xf[~keep] = np.nan
    return xf, bridged


def _rts(xf: np.ndarray, vf: np.ndarray, pf: np.ndarray, pp: np.ndarray, dts: np.ndarray,
         start: np.ndarray) -> np.ndarray:
    """Rauch-Tung-Striebel backward pass: (T, J, 3) smoothed positions.

    ``xf, vf`` are the filtered positions and velocities, ``pf, pp`` the (T, 3, J) filtered and
    predicted covariance entries (11, 12, 22); no smoothing links a frame to a track start.
    """
    out = np.empty_like(xf)
    xs, vs = xf[-1], vf[-1]
    out[-1] = xs
    for t in range(xf.shape[0] - 2, -1, -1):
        dt = dts[t + 1]
        f11, f12, f22 = pf[t]
        a, b, c = pp[t + 1]
        det = a * c - b * b
        m11, m21 = f11 + dt * f12, f12 + dt * f22  # Pf F^T = [[m11, f12], [m21, f22]], F = [[1, dt], [0, 1]]
        g11, g12 = (m11 * c - f12 * b) / det, (f12 * a - m11 * b) / det  # gain G = Pf F^T Pp^-1
        g21, g22 = (m21 * c - f22 * b) / det, (f22 * a - m21 * b) / det
        dx = xs - (xf[t] + dt * vf[t])
        dv = vs - vf[t]
        linked = ~start[t + 1][:, None]
        xs = np.where(linked, xf[t] + g11[:, None] * dx + g12[:, None] * dv, xf[t])
        vs = np.where(linked, vf[t] + g21[:, None] * dx + g22[:, None] * dv, vf[t])
        out[t] = xs
    return out


class OneEuroFilter:
    """The One-Euro filter of :func:`smooth` as a causal step function: one frame in, one frame out.

    The batch filter (:func:`smooth` with ONE_EURO) runs this step over its frames, so a live stream
    filtered frame by frame gets exactly the offline result. The cutoff adapts to the norm of each
    joint's filtered 3-D velocity. A joint's filter continues across a gap of at most ``max_gap_s``
    and restarts after a longer one.

    Parameters
    ----------
    n_joints : int
        J, the number of joints.
    params : OneEuroParams
        Filter settings.
    """

    def __init__(self, n_joints: int, params: OneEuroParams = OneEuroParams()) -> None:
        if not isinstance(params, OneEuroParams):
            raise BadInputError(f"params must be OneEuroParams, got {type(params).__name__}")
        self.params = params
        self._x, self._dx = np.zeros((n_joints, 3)), np.zeros((n_joints, 3))
        self._last = np.full(n_joints, -np.inf)  # time of each joint's last measurement

    def step(self, time: float, z: np.ndarray) -> np.ndarray:
        """Filter one frame.

        Parameters
        ----------
        time : float
            Frame time [s], later than the previous frame's.
        z : np.ndarray
            (J, 3) merged positions [m]; NaN where a joint is absent.

        Returns
        -------
        np.ndarray
            (J, 3) filtered positions [m]; NaN where ``z`` is NaN.
        """
        params, x, dx = self.params, self._x, self._dx
        if np.shape(z) != x.shape:
            raise BadInputError(f"a frame must have shape {x.shape}, got {np.shape(z)}")

        def smoothing(dt: np.ndarray, cutoff_hz: np.ndarray) -> np.ndarray:
            return 1.0 / (1.0 + 1.0 / (2 * np.pi * cutoff_hz * dt))

        measured = ~np.isnan(z[:, 0])
        dt = time - self._last
        new = measured & (dt > params.max_gap_s)
        cont = (measured & ~new)[:, None]
        dt = np.where(measured & ~new, dt, 1.0)[:, None]
        raw_speed = np.where(cont, (z - x) / dt, 0.0)
        dx = np.where(cont, dx + smoothing(dt, params.d_cutoff_hz) * (raw_speed - dx), dx)
        cutoff = params.min_cutoff_hz + params.beta * np.linalg.norm(dx, axis=1, keepdims=True)
        x = np.where(cont, x + smoothing(dt, cutoff) * (np.nan_to_num(z) - x), x)
        x = np.where(new[:, None], z, x)
        dx = np.where(new[:, None], 0.0, dx)
        self._last = np.where(measured, time, self._last)
        self._x, self._dx = x, dx
        out = np.full_like(x, np.nan)
        out[measured] = x[measured]
        return out


def _one_euro(times: np.ndarray, z: np.ndarray, params: OneEuroParams) -> np.ndarray:
    """(T, J, 3) One-Euro filtered positions (:class:`OneEuroFilter` over the frames); NaN where ``z`` is NaN."""
    out = np.full_like(z, np.nan)
    step = OneEuroFilter(z.shape[1], params).step
    for t in range(z.shape[0]):
        out[t] = step(times[t], z[t])
    return out


def _depths(topology: Topology) -> np.ndarray:
    """(J,) number of bones between each joint and the root."""
    depth = np.full(topology.n_joints, -1)
    parents = np.array(topology.parents)
    depth[parents == -1] = 0
    while np.any(depth < 0):
        depth = np.where((depth < 0) & (depth[parents] >= 0), depth[parents] + 1, depth)
    return depth


def median_bone_lengths(
    merged: MergedSkeleton, topology: Topology, *, min_reliability: Reliability = Reliability.LOW
) -> np.ndarray:
    """(J,) median length [m] over time of the bone from each joint's parent to the joint.

    Only frames where both ends have at least ``min_reliability`` count. NaN for the root and for
    bones never measured.
    """
    _check_topology(merged, topology)
    child = np.flatnonzero(np.array(topology.parents) >= 0)
    parent = np.array(topology.parents)[child]
    ok = (merged.reliability[:, child] >= min_reliability) & (merged.reliability[:, parent] >= min_reliability)
    length = np.linalg.norm(merged.positions[:, child] - merged.positions[:, parent], axis=-1)
    out = np.full(topology.n_joints, np.nan)
    out[child] = nanmedian(np.where(ok, length, np.nan), axis=0)
    return out


def enforce_bone_lengths(
    merged: MergedSkeleton, topology: Topology, *, min_reliability: Reliability = Reliability.LOW
) -> MergedSkeleton:
    """Give every bone a constant length: its median over time (:func:`median_bone_lengths`).

    From the root to the leaves, each child joint is placed at its (already adjusted) parent plus
    the bone's median length towards the child's own position, so a joint moves only along its
    bone and errors do not accumulate down a limb. A child whose parent is absent, whose bone
    never had a length, or which coincides with its parent keeps its position; the root never
    moves. Reliabilities and sources are kept.

    Parameters
    ----------
    merged : MergedSkeleton
        T frames of J joints.
    topology : Topology
        The J joints' tree.
    min_reliability : Reliability
        Frames whose bone ends are less reliable do not count towards the median lengths.

    Returns
    -------
    MergedSkeleton
        The adjusted skeleton; absent joints stay absent.
    """
    lengths = median_bone_lengths(merged, topology, min_reliability=min_reliability)
    parents = np.array(topology.parents)
    depth = _depths(topology)
    original = merged.positions
    positions = original.copy()
    for level in range(1, depth.max(initial=0) + 1):
        child = np.flatnonzero(depth == level)
        parent = parents[child]
        bone = original[:, child] - positions[:, parent]
        with np.errstate(invalid="ignore", divide="ignore"):
            direction = bone / np.linalg.norm(bone, axis=-1, keepdims=True)
        placed = positions[:, parent] + lengths[child][None, :, None] * direction
        positions[:, child] = np.where(np.isfinite(placed).all(axis=-1, keepdims=True), placed, original[:, child])
    return MergedSkeleton(merged.times, positions, merged.reliability, merged.n_cameras, merged.source_camera)


def _check_topology(merged: MergedSkeleton, topology: Topology) -> None:
    if topology.n_joints != merged.n_joints:
        raise BadInputError(f"topology {topology.name} has {topology.n_joints} joints, the skeleton {merged.n_joints}")
