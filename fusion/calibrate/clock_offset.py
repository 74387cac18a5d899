"""Residual clock offset between two cameras, estimated from the body's motion.

Clock convention as in :mod:`fusion.calibrate.sync`: ``offset_s`` is camera b's clock minus camera
a's clock.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from scipy.fft import irfft, next_fast_len, rfft

from fusion.arrays import nanmean
from fusion.calibrate.sync import check_positive, resample_joints, span_text
from fusion.errors import BadInputError, CalibrationError, StaticPersonError
from fusion.skeleton import SkeletonStream
from fusion.topology import Topology, TrackingState

_MAX_SIGNALS = 32
"""Number of inter-joint distance signals (largest variance) the clock-offset estimate uses."""

_MIN_MOTION_RATIO = 4.0
"""Signal variance must exceed this multiple of the frame-to-frame noise variance to count as motion."""

_MAD_TO_SIGMA = 1.4826
"""Median absolute deviation to standard deviation, for Gaussian data."""

_DESPIKE_HALF_WINDOW = 3
"""Half-width [frames] of the running median that finds outliers (bursts of up to 3 frames)."""

_HAMPEL_K = 5.0
"""A joint is an outlier beyond this many times its typical distance from its running median."""

_HAMPEL_FLOOR_M = 0.08
"""Distance [m] from the running median below which a joint is never an outlier."""

_MIN_MOTION_M = 0.01
"""Below this rms variation [m] of the distance signals a stream counts as static, whatever its noise.
Simulated Kinect v2 (+-45 degree pair, seeds 1-3, both cameras, the KIMORE-only and the seven-person
profile): a person standing still 2-11 mm (slow wobble, which second differences hardly see), one
one-arm hand lift 4.5-196 mm; real sessions 152-322 mm (27 Azure Kinect, 4 KIMORE: 123-435 mm)."""

_MIN_PEAK_SCORE = 0.5
"""Normalised cross-correlation a peak needs for :attr:`ClockOffset.converged`."""

_MIN_OVERLAP_FRACTION = 0.25
"""A lag is scored only if its overlapping samples are at least this fraction of the best lag's."""


@dataclass(frozen=True, eq=False)
class ClockOffset:
    """Result of :func:`estimate_clock_offset`.

    Attributes
    ----------
    offset_s : float
        Estimated clock offset [s], camera b's clock minus camera a's (see the module docstring).
    lags_s : np.ndarray
        (K,) candidate offsets [s] that were scored, evenly spaced over ``[-max_offset_s, max_offset_s]``.
    score : np.ndarray
        (K,) normalised cross-correlation of the two cameras' motion signals at each lag, in [-1, 1];
        NaN where the streams overlap too little.
    peak_score : float
        Score at the chosen lag.
    converged : bool
        True when the maximum lies strictly inside the searched range and scores at least 0.5.
        False means the offset is likely outside ``max_offset_s`` or the motion does not match.
    n_signals : int
        Number of inter-joint distance signals used.
    widened : bool
        Found by the second, wider search of :func:`estimate_clock_offset_widening`.
    """

    offset_s: float
    lags_s: np.ndarray
    score: np.ndarray
    peak_score: float
    converged: bool
    n_signals: int
    widened: bool = False

    def gain_over_zero(self) -> float:
        """How much the peak scores above the lag nearest 0 (the clocks as given): small for a flat or
        periodic score, where the peak's place is not evidence against the given clocks; NaN where lag 0
        is not scored (its overlap of tracked samples is under a quarter of the best lag's), so that a lag
        with more overlap is not taken for a better one."""
        return float(self.peak_score - self.score[int(np.argmin(np.abs(self.lags_s)))])

    def __post_init__(self) -> None:
        lags = np.asarray(self.lags_s, dtype=np.float64)
        score = np.asarray(self.score, dtype=np.float64)
        if lags.ndim != 1 or score.shape != lags.shape:
            raise BadInputError(f"lags_s and score must be 1-D of one length, got {lags.shape} and {score.shape}")
        for name, arr in (("lags_s", lags), ("score", score)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)


def estimate_clock_offset(
    stream_a: SkeletonStream,
    stream_b: SkeletonStream,
    *,
    max_offset_s: float = 0.2,
    min_state: TrackingState = TrackingState.TRACKED,
    grid_step_s: float = 0.005,
    max_gap_s: float = 0.1,
    names: tuple[str, str] = ("a", "b"),
) -> ClockOffset:
    """Estimate the residual clock offset between two cameras from the body motion alone.

    Needs no extrinsics: each camera's signals are distances between joints, which do not depend on
    the camera pose. Distances of a joint pair and of its left/right mirror pair are summed, so a
    back-facing (left/right swapped) skeleton gives the same signal. Bones (rigid lengths) are left
    out and the 32 signals that vary most in both cameras are kept. Outlier positions are dropped
    first (a Hampel filter per joint, 7 frames wide), then every joint is interpolated linearly on a
    common grid of step ``grid_step_s``, bridging short gaps from that joint's own neighbouring
    frames. The lag maximising the normalised cross-correlation of the two cameras' signals
    (summed over signals, so that the most varying ones weigh most) is refined to sub-grid
    precision by a parabola through the peak and its two neighbours.

    Parameters
    ----------
    stream_a, stream_b : SkeletonStream
        The same person seen by cameras a and b (same topology).
    max_offset_s : float
        Largest offset [s] searched, in both directions. Keep it below half the period of any
        repetitive motion, or the search may lock onto the wrong repetition.
    min_state : TrackingState
        Joints below this state are ignored.
    grid_step_s : float
        Step [s] of the common resampling grid and of the scored lags.
    max_gap_s : float
        Longest interval [s] between two frames that have a joint which is interpolated across.
    names : the cameras' names, for messages.

    Returns
    -------
    ClockOffset
        ``offset_s`` is camera b's clock minus camera a's: a frame stamped ``ts_b`` by camera b was
        captured at ``ts_b - offset_s`` on camera a's clock.

    Raises
    ------
    CalibrationError
        The recordings do not overlap in time, or share no well-tracked joint pairs;
        :class:`~fusion.errors.StaticPersonError` when the person is (nearly) static, so there is no
        motion to align.
    """
    if stream_a.topology != stream_b.topology:
        raise BadInputError(f"streams have different topologies: {stream_a.topology.name} and {stream_b.topology.name}")
    check_positive("max_offset_s", max_offset_s)
    check_positive("grid_step_s", grid_step_s)
    if grid_step_s * 2 > max_offset_s:
        raise BadInputError(f"grid_step_s ({grid_step_s} s) must be at most half of max_offset_s ({max_offset_s} s)")
    ts_a, ts_b = stream_a.timestamps, stream_b.timestamps
    lo = max(ts_a[0], ts_b[0] - max_offset_s) if ts_a.size and ts_b.size else np.inf
    hi = min(ts_a[-1], ts_b[-1] + max_offset_s) if ts_a.size and ts_b.size else -np.inf
    if not hi - lo > 2 * max_offset_s:
        raise CalibrationError(
            f"clock offset: the recordings do not overlap in time by more than {2 * max_offset_s:.3g} s "
            f"(camera a spans {span_text(ts_a)}, camera b {span_text(ts_b)}, searching offsets up to "
            f"+-{max_offset_s} s); record both cameras at the same time, or raise max_offset_s if the "
            "clocks differ by more"
        )
    pairs = _distance_pairs(stream_a.topology)
    pos_a, pos_b = _clean_positions(stream_a, min_state), _clean_positions(stream_b, min_state)
    spread_a = _motion_spread(names[0], _distances(pos_a, pairs), _kept_share(stream_a, pos_a), min_state)
    spread_b = _motion_spread(names[1], _distances(pos_b, pairs), _kept_share(stream_b, pos_b), min_state)
    usable = np.flatnonzero((spread_a > 0) & (spread_b > 0))
    if usable.size == 0:
        raise CalibrationError(
            f"clock offset: no pair of joints is {min_state.name} in both cameras often enough to "
            "follow its motion; record with the whole body in view of both cameras"
        )
    chosen = usable[np.argsort(-spread_a[usable] * spread_b[usable], kind="stable")[:_MAX_SIGNALS]]
    pairs = pairs[chosen]

    n_lag = int(np.floor(max_offset_s / grid_step_s))
    grid_a = lo + grid_step_s * np.arange(int(np.floor((hi - lo) / grid_step_s)) + 1)
    grid_b = lo + grid_step_s * np.arange(-n_lag, grid_a.size + n_lag)
    sig_a = _distances(resample_joints(ts_a, pos_a, grid_a, max_gap_s), pairs)
    sig_b = _distances(resample_joints(ts_b, pos_b, grid_b, max_gap_s), pairs)
    score = _normalised_xcorr(sig_a, sig_b)
    lags = grid_step_s * np.arange(-n_lag, n_lag + 1)
    if np.all(np.isnan(score)):
        raise CalibrationError(
            "clock offset: the two cameras never track the same joints at overlapping times; record "
            "with the whole body in view of both cameras"
        )
    k = int(np.nanargmax(score))
    peak = float(score[k])
    interior = 0 < k < score.size - 1 and np.all(np.isfinite(score[k - 1 : k + 2]))
    offset = float(lags[k])
    if interior:
        y0, y1, y2 = score[k - 1 : k + 2]
        curvature = y0 - 2 * y1 + y2
        interior = curvature < 0
        if interior:
            offset += grid_step_s * 0.5 * (y0 - y2) / curvature
    return ClockOffset(
        offset_s=offset,
        lags_s=lags,
        score=score,
        peak_score=peak,
        converged=bool(interior and peak >= _MIN_PEAK_SCORE),
        n_signals=pairs.shape[0],
    )


WIDE_CLOCK_SEARCH_S = 2.5
"""Second, wider clock-offset search [s] when the first one does not converge (its best lag need not lie
at its edge: a turn 1.6 s apart peaked inside +-0.2 s); offsets of 0.5-2 s are then found to 0.02 s."""

MIN_GAIN_OVER_ZERO = 0.2
"""A lag found by a wide search (the widening, :func:`clock_residuals`) counts only when its peak scores
at least this much above lag 0 (:meth:`ClockOffset.gain_over_zero`). Measured on fma_2cam seed 19, whose
slow salute gives a flat score: 0.81 at the true lag, 0.94 at a false one 0.63 s away (gain 0.14); true
offsets of 0.3-3 s gain 0.3 or more."""


def estimate_clock_offset_widening(stream_a: SkeletonStream, stream_b: SkeletonStream, max_offset_s: float,
                                   names: tuple[str, str] = ("a", "b")) -> ClockOffset:
    """:func:`estimate_clock_offset` within ``max_offset_s`` [s]; when that does not converge (the clocks may
    be further apart), once more within :data:`WIDE_CLOCK_SEARCH_S`, whose result is taken if it
    converges and beats lag 0 by :data:`MIN_GAIN_OVER_ZERO` (``widened``)."""
    est = estimate_clock_offset(stream_a, stream_b, max_offset_s=max_offset_s, names=names)
    if est.converged or max_offset_s >= WIDE_CLOCK_SEARCH_S:
        return est
    wide = estimate_clock_offset(stream_a, stream_b, max_offset_s=WIDE_CLOCK_SEARCH_S, names=names)
    clear = wide.converged and wide.gain_over_zero() >= MIN_GAIN_OVER_ZERO
    return dataclasses.replace(wide, widened=True) if clear else est


def _normalised_xcorr(sig_a: np.ndarray, sig_b: np.ndarray) -> np.ndarray:
    """(2M+1,) masked normalised cross-correlation of (N, S) with (N + 2M, S) signal arrays.

    Entry ``l`` correlates ``sig_a[k]`` with ``sig_b[k + l]`` over the samples valid in both.
    """
    m_a, m_b = np.isfinite(sig_a), np.isfinite(sig_b)
    a = np.where(m_a, sig_a - nanmean(sig_a, axis=0, empty=0.0), 0.0)
    b = np.where(m_b, sig_b - nanmean(sig_b, axis=0, empty=0.0), 0.0)
    m_a, m_b = m_a.astype(float), m_b.astype(float)
    n_a, n_b = sig_a.shape[0], sig_b.shape[0]
    size = next_fast_len(n_a + n_b - 1, real=True)
    spectra = {name: rfft(np.ascontiguousarray(x.T), size) for name, x in  # (S, F): each signal's spectrum
               (("a", a[::-1]), ("aa", (a * a)[::-1]), ("ma", m_a[::-1]), ("b", b), ("bb", b * b), ("mb", m_b))}

    def xcorr(x: str, y: str) -> np.ndarray:
        """Sum over the signals of the correlations at every lag (summed in the frequency domain)."""
        return irfft(np.einsum("sf,sf->f", spectra[x], spectra[y]), size)[n_a - 1 : n_b]

    num = xcorr("a", "b")
    energy_a = xcorr("aa", "mb")
    energy_b = xcorr("ma", "bb")
    count = xcorr("ma", "mb")
    with np.errstate(invalid="ignore", divide="ignore"):
        score = num / np.sqrt(energy_a * energy_b)
    score[(count < _MIN_OVERLAP_FRACTION * count.max()) | ~(energy_a > 0) | ~(energy_b > 0)] = np.nan
    return np.clip(score, -1.0, 1.0)


def _clean_positions(stream: SkeletonStream, min_state: TrackingState) -> np.ndarray:
    """(T, J, 3) positions [m] without joints below ``min_state`` and without outliers (NaN there).

    Outliers are found per joint by a Hampel filter: a position is dropped where it lies farther
    from the joint's running median over the frame and its 3 + 3 neighbours than ``_HAMPEL_K``
    times the joint's median such distance (and at least ``_HAMPEL_FLOOR_M``), or where fewer than
    4 of those 7 frames have the joint. Kept positions are not altered, so the signal is neither
    smoothed nor shifted in time.
    """
    positions = np.where((stream.states >= min_state)[..., None], stream.positions, np.nan)
    half = _DESPIKE_HALF_WINDOW
    padded = np.pad(positions, ((half, half), (0, 0), (0, 0)), constant_values=np.nan)
    median, n = _nanmedian(np.lib.stride_tricks.sliding_window_view(padded, 2 * half + 1, axis=0))
    deviation = np.linalg.norm(positions - median, axis=-1)
    limit = np.maximum(_HAMPEL_K * np.nan_to_num(_nanmedian(deviation.T)[0]), _HAMPEL_FLOOR_M)
    keep = (n[..., 0] > half) & (deviation <= limit)
    return np.where(keep[..., None], positions, np.nan)


def _nanmedian(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Median over the last axis ignoring NaN (NaN where nothing is finite), and the finite count."""
    finite = np.isfinite(x)
    n = finite.sum(axis=-1)
    s = np.sort(np.where(finite, x, np.inf), axis=-1)
    lo = np.take_along_axis(s, np.maximum((n - 1) // 2, 0)[..., None], axis=-1)[..., 0]
    hi = np.take_along_axis(s, np.minimum(n // 2, x.shape[-1] - 1)[..., None], axis=-1)[..., 0]
    return np.where(n > 0, 0.5 * (lo + hi), np.nan), n


def _distance_pairs(topo: Topology) -> np.ndarray:
    """(S, 2, 2) joint pairs: a pair and its left/right mirror (itself if symmetric), bones left out."""
    mirror = topo.mirror
    bones = {frozenset(map(int, b)) for b in topo.bones}
    groups: dict[frozenset, tuple] = {}
    for i in range(topo.n_joints):
        for j in range(i + 1, topo.n_joints):
            pair, image = (i, j), tuple(sorted((int(mirror[i]), int(mirror[j]))))
            key = frozenset((pair, image))
            if frozenset(pair) not in bones and key not in groups:
                groups[key] = (pair, image)
    return np.array(list(groups.values()), dtype=np.int64).reshape(-1, 2, 2)


def _distances(positions: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """(T, S) distance [m] of each pair plus that of its mirror pair; NaN where a joint is absent."""
    first, second = pairs[..., 0].ravel(), pairs[..., 1].ravel()
    axes = np.ascontiguousarray(np.moveaxis(positions, -1, 0))  # (3, T, J): each axis contiguous
    squared = sum((x[:, first] - x[:, second]) ** 2 for x in axes)
    return np.sqrt(squared).reshape(positions.shape[0], -1, 2).sum(axis=-1)


def _kept_share(stream: SkeletonStream, positions: np.ndarray) -> float:
    """Share of the stream's joint samples with a position that the clock estimate keeps."""
    return float(np.isfinite(positions[..., 0]).sum() / max(np.isfinite(stream.positions[..., 0]).sum(), 1))


def _motion_spread(camera: str, signals: np.ndarray, kept: float, min_state: TrackingState) -> np.ndarray:
    """(S,) robust spread [m] of each (T, S) signal over time; 0 where seen in fewer than 3 frames.

    Spread and frame-to-frame noise (from second differences, which cancel smooth motion) are
    median absolute deviations scaled to standard deviations, so outliers inflate neither. Raises
    StaticPersonError when the spread does not clearly exceed the noise: the person is (nearly) static,
    or too few joint samples are kept (``kept`` under half: the message says so) to see the motion."""
    median, n = _nanmedian(signals.T)
    spread = np.where(n >= 3, _MAD_TO_SIGMA * _nanmedian(np.abs(signals - median).T)[0], 0.0)
    curvature = np.diff(signals, n=2, axis=0)  # white noise of std s gives std sqrt(6) s here
    noise = _MAD_TO_SIGMA / np.sqrt(6) * _nanmedian(np.abs(curvature - _nanmedian(curvature.T)[0]).T)[0]
    used = spread > 0
    if not used.any():
        return spread
    motion, jitter = np.sqrt(np.mean(spread[used] ** 2)), np.sqrt(np.mean(np.nan_to_num(noise[used]) ** 2))
    if not motion**2 > _MIN_MOTION_RATIO * jitter**2 + _MIN_MOTION_M**2:
        few = f"; only {100 * kept:.0f} % of its joint samples are {min_state.name}, which may hide it" if kept < 0.5 else ""
        raise StaticPersonError(
            f"clock offset: the person is (nearly) static in camera {camera}: inter-joint distances vary "
            f"by {motion * 1e3:.1f} mm against {jitter * 1e3:.1f} mm frame-to-frame noise (robust rms){few}; "
            "record the person moving (arm raises, steps) while both cameras see them"
        )
    return spread


CLOCK_CHECK_SEARCH_S = 10.0
"""Widest lag [s] :func:`clock_residuals` searches (less for short sessions: a quarter of the overlap)."""

CLOCK_CHECK_TOLERANCE_S = 0.25
"""A residual clock offset beyond this [s] means the calibration's offsets do not fit the recording."""

CLOCK_CHECK_MIN_SCORE = 0.7
"""Score the residual's peak needs to count (a clear match of the motion; measured: 0.81 at the true lag
of a simulated fma_2cam session, 0.54-0.59 at false peaks of sessions with little or repetitive motion)."""



def clock_residuals(streams: dict[str, SkeletonStream], offsets_s: dict[str, float],
                    reference: str) -> dict[str, ClockOffset | None]:
    """What remains of each camera's clock offset to ``reference`` once ``offsets_s`` are applied.

    Searched on a 20 ms grid within +-:data:`CLOCK_CHECK_SEARCH_S` (or a quarter of the two streams'
    overlap), so that calibration offsets several seconds wrong (another session's, a clock reset) are
    found; measured on a simulated 30 s session: errors of 0.1-3 s are found to 5 ms.

    Parameters
    ----------
    streams : camera name -> its skeleton stream (its own clock).
    offsets_s : camera name -> clock offset [s] (the calibration's; only differences matter).
    reference : the camera the others are compared with.

    Returns
    -------
    dict
        Per camera other than ``reference``: the residual (``offset_s`` ~ 0 when the offsets fit), or
        None where the streams overlap too little or the person does not move enough to tell.
        :func:`contradicts` says whether a residual is evidence that the offsets are wrong.
    """
    ref = streams[reference]
    out: dict[str, ClockOffset | None] = {}
    for name, stream in streams.items():
        if name == reference:
            continue
        shifted = dataclasses.replace(stream, timestamps=stream.timestamps - (offsets_s[name] - offsets_s[reference]))
        overlap = min(ref.timestamps[-1], shifted.timestamps[-1]) - max(ref.timestamps[0], shifted.timestamps[0])
        reach = min(CLOCK_CHECK_SEARCH_S, overlap / 4)
        try:
            out[name] = None if reach < 0.5 else estimate_clock_offset(ref, shifted, max_offset_s=reach,
                                                                       grid_step_s=0.02)
        except CalibrationError:
            out[name] = None
    return out


def contradicts(residual: ClockOffset | None) -> bool:
    """Whether a :func:`clock_residuals` result is clear evidence that the offsets are wrong: converged
    beyond :data:`CLOCK_CHECK_TOLERANCE_S`, peaking at :data:`CLOCK_CHECK_MIN_SCORE` or more and at least
    :data:`MIN_GAIN_OVER_ZERO` above the score at lag 0."""
    if residual is None or not residual.converged or abs(residual.offset_s) <= CLOCK_CHECK_TOLERANCE_S:
        return False
    return residual.peak_score >= CLOCK_CHECK_MIN_SCORE and residual.gain_over_zero() >= MIN_GAIN_OVER_ZERO
