"""Sensor-check section of the camera clocks: rate, dropped frames, timestamp jitter and offsets.
"""

from __future__ import annotations

import numpy as np

from scenarios.sensors.check.check_results import Section, around, relative
from sim.camera_clock import ClockModel, sample_clock

_CLOCK_CAMERAS = 6


_CLOCK_S = 600.0


_RATE_TOL_HZ = 1e-3


_OFFSET_TOL_S = 5e-5


_JITTER_REL_TOL = 0.05


def check_clocks(*, rng: np.random.Generator, model: ClockModel = ClockModel()) -> Section:
    """Several free-running camera clocks: frame rate, drops, jitter from timestamps; offsets against truth.

    A reader's view: the period is the median timestamp step, each step is counted as a whole number
    of periods (the gaps are dropped frames), and a line fitted to timestamp versus frame number gives
    the rate and, from its residuals, the jitter. The offset to true time uses the simulator's truth.
    """
    checks, residuals = [], []
    delivered = dropped = 0
    for c in range(1, _CLOCK_CAMERAS + 1):
        clock = sample_clock(_CLOCK_S, model, rng=rng)
        ts = clock.camera_timestamps
        steps = np.rint(np.diff(ts) / np.median(np.diff(ts)))
        frame = np.concatenate([[0.0], np.cumsum(steps)])
        slope, intercept = np.polyfit(frame, ts, 1)
        residuals.append(ts - (intercept + slope * frame))
        delivered += ts.size
        dropped += int(np.sum(steps - 1))
        checks += [
            around(f"cam{c}", "frame rate", "Hz", 1.0 / slope, model.rate_hz, _RATE_TOL_HZ, f"+-{_RATE_TOL_HZ:g} Hz"),
            around(f"cam{c}", "offset: mean(timestamp - true time)", "ms", 1e3 * np.mean(ts - clock.true_times),
                    1e3 * clock.offset_s, 1e3 * _OFFSET_TOL_S, f"+-{1e3 * _OFFSET_TOL_S:g} ms"),
        ]
    fraction = dropped / (delivered + dropped)
    p = model.drop_probability
    se = np.sqrt(p * (1 - p) / (delivered + dropped))
    jitter = np.concatenate(residuals).std()
    checks += [
        around(f"all {_CLOCK_CAMERAS} cameras", "dropped frames", "fraction", fraction, p, 3 * se,
                "3 binomial std errors", lowest=0.0, **{"frames delivered": delivered, "frames dropped": dropped}),
        relative(f"all {_CLOCK_CAMERAS} cameras", "timestamp jitter std", "ms", 1e3 * jitter,
                  1e3 * model.jitter_sigma_s, _JITTER_REL_TOL),
    ]
    offsets = [c.expected for c in checks if c.quantity.startswith("offset")]
    method = (
        f"{_CLOCK_CAMERAS} cameras with the default clock model ({model.rate_hz:g} Hz, offset sd "
        f"{1e3 * model.offset_sigma_s:g} ms, jitter {1e3 * model.jitter_sigma_s:g} ms, drop probability "
        f"{model.drop_probability:g}) record {_CLOCK_S:g} s each. From the timestamps alone, as a reader would: the "
        "period is the median step; each step counts as a whole number of periods, the extra ones are dropped "
        "frames; a line through timestamp versus frame number gives the rate, its residuals the jitter. The offset "
        "to true time (the simulator's truth) is the mean of timestamp minus true capture time; expected is the "
        f"offset the clock drew (these {_CLOCK_CAMERAS}: {', '.join(f'{o:+.2f}' for o in offsets)} ms). "
        "Tolerances are far above the estimates' standard errors, except for the drop fraction (3 standard errors)."
    )
    return Section("clocks", method, tuple(checks))
