"""Camera clocks: when a free-running sensor captures frames and what timestamps it writes.

Each camera runs on its own oscillator at a nominal ``rate_hz`` with a random phase, is synchronised
to true time only up to a residual offset (what NTP leaves), may drift, stamps each frame with a
little jitter and drops a few frames. True time starts at 0 s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fusion.errors import BadInputError

_JITTER_CLIP = 0.4
"""Timestamp jitter is clipped to this fraction of a frame period so timestamps stay increasing."""


@dataclass(frozen=True)
class ClockModel:
    """Parameters of one camera's clock.

    Attributes
    ----------
    rate_hz : float
        Nominal frame rate on the camera's own clock [Hz].
    offset_sigma_s : float
        Standard deviation of the camera clock's offset to true time [s], drawn per camera when
        ``offset_s`` is None (the residual after NTP synchronisation).
    jitter_sigma_s : float
        Per-frame timestamp jitter [s]; at most a tenth of a frame period.
    drop_probability : float
        Probability that a frame is lost, independently per frame, in [0, 1).
    drift_ppm : float
        Camera clock rate error [parts per million]; positive runs fast.
    phase_s : float or None
        Time of the first capture [s] in [0, 1 / rate_hz); None draws it uniformly.
    offset_s : float or None
        Fixed clock offset [s]; None draws it from N(0, offset_sigma_s).
    """

    rate_hz: float = 30.0
    offset_sigma_s: float = 0.005
    jitter_sigma_s: float = 0.001
    drop_probability: float = 0.005
    drift_ppm: float = 0.0
    phase_s: float | None = None
    offset_s: float | None = None

    def __post_init__(self) -> None:
        values = [self.rate_hz, self.offset_sigma_s, self.jitter_sigma_s, self.drop_probability, self.drift_ppm]
        values += [v for v in (self.phase_s, self.offset_s) if v is not None]
        if not np.all(np.isfinite(values)):
            raise BadInputError(f"clock parameters must be finite, got {self}")
        if self.rate_hz <= 0:
            raise BadInputError(f"rate_hz must be positive, got {self.rate_hz}")
        if self.offset_sigma_s < 0 or self.jitter_sigma_s < 0:
            raise BadInputError("offset_sigma_s and jitter_sigma_s must be >= 0")
        if self.jitter_sigma_s > 0.1 / self.rate_hz:
            raise BadInputError(
                f"jitter_sigma_s {self.jitter_sigma_s} s exceeds a tenth of the frame period {1 / self.rate_hz} s"
            )
        if not 0 <= self.drop_probability < 1:
            raise BadInputError(f"drop_probability must lie in [0, 1), got {self.drop_probability}")
        if abs(self.drift_ppm) >= 1e4:
            raise BadInputError(f"drift_ppm must be below 1e4 in magnitude, got {self.drift_ppm}")
        if self.phase_s is not None and not 0 <= self.phase_s < 1 / self.rate_hz:
            raise BadInputError(f"phase_s must lie in [0, {1 / self.rate_hz}) s, got {self.phase_s}")


@dataclass(frozen=True, eq=False)
class ClockSamples:
    """The frames one camera delivered.

    Attributes
    ----------
    true_times : np.ndarray
        (T,) float64 true time [s] at which each delivered frame was captured.
    camera_timestamps : np.ndarray
        (T,) float64 timestamp [s] the camera wrote for each frame, strictly increasing.
    frame_index : np.ndarray
        (T,) int64 index of each delivered frame in the camera's capture sequence (gaps are drops).
    phase_s : float
        True time of capture 0 [s].
    offset_s : float
        Camera clock offset [s]: ``camera = (1 + drift) * true + offset + jitter``.
    """

    true_times: np.ndarray
    camera_timestamps: np.ndarray
    frame_index: np.ndarray
    phase_s: float
    offset_s: float

    def __post_init__(self) -> None:
        arrays = {
            "true_times": np.asarray(self.true_times, dtype=np.float64),
            "camera_timestamps": np.asarray(self.camera_timestamps, dtype=np.float64),
            "frame_index": np.asarray(self.frame_index, dtype=np.int64),
        }
        shapes = {a.shape for a in arrays.values()}
        if len(shapes) != 1 or arrays["true_times"].ndim != 1:
            raise BadInputError(f"clock arrays must be 1-D of one length, got shapes {sorted(shapes)}")
        for name in ("true_times", "camera_timestamps"):
            if np.any(np.diff(arrays[name]) <= 0):
                raise BadInputError(f"{name} must be strictly increasing")
        for name, arr in arrays.items():
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @property
    def n_frames(self) -> int:
        """Number of delivered frames T."""
        return self.true_times.shape[0]


def sample_clock(duration_s: float, model: ClockModel, *, rng: np.random.Generator) -> ClockSamples:
    """Capture times and written timestamps of one camera recording for ``duration_s`` seconds.

    Captures happen at ``phase + k / ((1 + drift) * rate_hz)`` true seconds (the camera believes it
    runs at exactly ``rate_hz``) for every capture inside ``[0, duration_s)``; each is dropped with
    ``model.drop_probability``. The written timestamp is ``(1 + drift) * true + offset + jitter``,
    the jitter being Gaussian clipped to 0.4 frame periods.

    Parameters
    ----------
    duration_s : float
        Recording length in true time [s], positive.
    model : ClockModel
        Clock parameters.
    rng : np.random.Generator
        Source of the phase, offset, jitter and drops.

    Returns
    -------
    ClockSamples
        The delivered frames (possibly none).
    """
    if not np.isfinite(duration_s) or duration_s <= 0:
        raise BadInputError(f"duration_s must be positive and finite, got {duration_s}")
    period = 1.0 / model.rate_hz
    scale = 1.0 + 1e-6 * model.drift_ppm
    phase = rng.uniform(0.0, period) if model.phase_s is None else model.phase_s
    offset = rng.normal(0.0, model.offset_sigma_s) if model.offset_s is None else model.offset_s
    n = int(np.ceil((duration_s - phase) * scale / period))
    k = np.arange(max(n, 0))
    true_times = phase + k * period / scale
    k, true_times = k[true_times < duration_s], true_times[true_times < duration_s]
    clip = _JITTER_CLIP * period
    jitter = np.clip(rng.normal(0.0, model.jitter_sigma_s, k.size), -clip, clip)
    keep = rng.random(k.size) >= model.drop_probability
    stamps = scale * true_times + offset + jitter
    return ClockSamples(true_times[keep], stamps[keep], k[keep], float(phase), float(offset))
