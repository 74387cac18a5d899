"""Hypothesis strategies that draw complete scenarios for property-based tests of calibration and fusion.

Every value is drawn from hypothesis (numbers, choices, seeds), never from a random generator inside
the strategy, so failing cases shrink: towards fewer cameras, the lower bound of each range, the first
choice of each list, seed 0. Defaults stay inside what the simulated sensors can honour (cameras within
the depth range of the subject, above the floor, looking at the body).

```python
from hypothesis import given
from scenarios.testing import strategies as mb
@given(mb.scenarios(rig=mb.rigs(max_cameras=4)))
def test_my_calibration(scenario): ...
```
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence

from hypothesis import strategies as st

from scenarios.api import (
    CameraConfig,
    RigConfig,
    Scenario,
    SegmentConfig,
    SensorConfig,
    SubjectConfig,
)
from scenarios.config import NoiseLevel, ReplayConfig, SegmentKind
from sim.sensor_profile import load_profile

PROFILES = ("kinect_v2", "azure_kinect")
"""Sensor profiles the sensor strategy draws from by default (built-in names or profile TOML paths)."""

seeds = st.integers(min_value=0, max_value=2**31 - 1)
"""Scenario seeds (shrink towards 0)."""


@functools.cache
def profile_topology(profile: str) -> str:
    """Name of the joint topology a sensor profile's tracker reports (the subject must use it)."""
    return load_profile(profile).topology.name


def _deg(lo: float, hi: float) -> st.SearchStrategy[float]:
    return st.floats(min_value=lo, max_value=hi, allow_nan=False, allow_infinity=False)


@st.composite
def ring_rigs(draw: st.DrawFn, min_cameras: int = 2, max_cameras: int = 6, *, radius_m: tuple[float, float] = (1.5, 3.2),
              height_m: tuple[float, float] = (0.6, 2.0), target_height_m: tuple[float, float] = (0.7, 1.3),
              arc_deg: tuple[float, float] = (60.0, 360.0)) -> RigConfig:
    """Cameras evenly spaced on an arc around the subject (a full ring at ``arc_deg`` 360).

    Parameters
    ----------
    min_cameras, max_cameras : camera count range (2-6 is the paper's span).
    radius_m : horizontal distance to the subject [m].
    height_m : lens height above the floor [m].
    target_height_m : height they aim at on the subject's axis [m]; with ``height_m`` it sets the tilt.
    arc_deg : the arc the cameras span, centred on the subject's front [deg].
    """
    n = draw(st.integers(min_value=min_cameras, max_value=max_cameras))
    arc = draw(_deg(*arc_deg))
    step = arc / n if arc >= 359.999 else arc / max(n - 1, 1)
    start = -arc / 2 if arc < 359.999 else draw(_deg(-180.0, 180.0))
    angles = [float(start + k * step) for k in range(n)]
    return RigConfig(angles_deg=angles, n_cameras=n, radius_m=draw(_deg(*radius_m)), height_m=draw(_deg(*height_m)),
                     target_height_m=draw(_deg(*target_height_m)))


@st.composite
def placed_rigs(draw: st.DrawFn, min_cameras: int = 2, max_cameras: int = 6, *,
                distance_m: tuple[float, float] = (1.5, 3.2), height_m: tuple[float, float] = (0.6, 2.0),
                bearing_deg: tuple[float, float] = (-180.0, 180.0), aim_offset_m: float = 0.3) -> RigConfig:
    """Cameras anywhere in a room: each at its own bearing from the subject's front [deg], distance [m]
    and height [m], aimed at the subject's trunk give or take ``aim_offset_m`` [m] in each axis."""
    n = draw(st.integers(min_value=min_cameras, max_value=max_cameras))
    cameras = []
    for k in range(n):
        bearing = math.radians(draw(_deg(*bearing_deg)))
        d = draw(_deg(*distance_m))
        position = [d * math.cos(bearing), d * math.sin(bearing), draw(_deg(*height_m))]
        target = [draw(_deg(-aim_offset_m, aim_offset_m)), draw(_deg(-aim_offset_m, aim_offset_m)),
                  1.0 + draw(_deg(-aim_offset_m, aim_offset_m))]
        cameras.append(CameraConfig(name=f"cam{k + 1}", position_m=position, target_m=target))
    return RigConfig(camera=cameras)


def rigs(min_cameras: int = 2, max_cameras: int = 6) -> st.SearchStrategy[RigConfig]:
    """Rings and arcs (:func:`ring_rigs`) or free placements (:func:`placed_rigs`)."""
    return st.one_of(ring_rigs(min_cameras, max_cameras), placed_rigs(min_cameras, max_cameras))


@st.composite
def subjects(draw: st.DrawFn, topology: str = "kinect_v2", *, patients: bool = True) -> SubjectConfig:
    """Who performs: height 1.50-1.95 m, build, and (``patients``) a patient group with an affected side."""
    groups = ["healthy", "mild", "moderate_severe"] if patients else ["healthy"]
    group = draw(st.sampled_from(groups))
    side = None if group == "healthy" else draw(st.sampled_from(["right", "left"]))
    return SubjectConfig(height_m=draw(_deg(1.5, 1.95)), build=draw(st.sampled_from(["average", "slim", "heavy"])),
                         group=group, affected_side=side, topology=topology)


@st.composite
def motions(draw: st.DrawFn, *, turn_s: tuple[float, float] = (8.0, 20.0), max_items: int = 3,
            clips: Sequence[str] = ()) -> tuple[SegmentConfig, ...]:
    """A session: a short idle, a turn in place (the views a body calibration needs), then up to
    ``max_items`` scripted Fugl-Meyer items (salute, hand lift; side, 1-3 repetitions) or, when
    ``clips`` names motion / recording / C3D / TRC / BVH files, replayed clips among them."""
    segments = [SegmentConfig(SegmentKind.IDLE, duration_s=1.0),
                SegmentConfig(SegmentKind.CALIBRATION_TURN, duration_s=draw(_deg(*turn_s)))]
    kinds = [SegmentKind.SALUTE, SegmentKind.HAND_LIFT] + ([SegmentKind.REPLAY] if clips else [])
    for _ in range(draw(st.integers(min_value=0, max_value=max_items))):
        kind = draw(st.sampled_from(kinds))
        if kind is SegmentKind.REPLAY:
            segments.append(SegmentConfig(kind, replay=ReplayConfig(source=draw(st.sampled_from(list(clips))))))
        else:
            segments.append(SegmentConfig(kind, side=draw(st.sampled_from(["right", "left"])),
                                          repetitions=draw(st.integers(min_value=1, max_value=3))))
    return tuple(segments)


@st.composite
def sensor_conditions(draw: st.DrawFn, profiles: Sequence[str] = PROFILES, *, noise: bool = True,
                      max_clock_offset_sd_ms: float = 30.0, max_jitter_ms: float = 3.0,
                      max_drop_probability: float = 0.1, noise_scale: tuple[float, float] = (1.0, 1.0),
                      flips: bool = False) -> SensorConfig:
    """The sensor: a profile (a person of its population), tracker noise on or (``noise``) off, a scale
    of its jitter drawn from ``noise_scale``, back-facing flips on or (``flips``: drawn) off, the spread
    of the cameras' clock offsets [ms], per-frame clock jitter [ms] and the share of dropped frames;
    skeletons only (no depth frames, fast)."""
    return SensorConfig(
        profile=draw(st.sampled_from(list(profiles))),
        tracker_noise=draw(st.sampled_from([NoiseLevel.DEFAULT, NoiseLevel.NONE])) if noise else NoiseLevel.DEFAULT,
        depth_rate_hz=0.0,
        clock_offset_sd_ms=draw(_deg(0.0, max_clock_offset_sd_ms)),
        clock_jitter_ms=draw(_deg(0.0, max_jitter_ms)),
        drop_probability=draw(_deg(0.0, max_drop_probability)),
        noise_scale=draw(_deg(*noise_scale)),
        flips=draw(st.booleans()) if flips else True,
    )


@st.composite
def scenarios(draw: st.DrawFn, *, rig: st.SearchStrategy[RigConfig] | None = None,
              sensors: st.SearchStrategy[SensorConfig] | None = None, motion: st.SearchStrategy | None = None,
              patients: bool = True, seed: st.SearchStrategy[int] = seeds) -> Scenario:
    """A complete scenario: rig (default :func:`rigs`), sensor (default :func:`sensor_conditions`), a
    subject matching the sensor's joint topology, motion (default :func:`motions`) and a seed."""
    sensor = draw(sensors if sensors is not None else sensor_conditions())
    topology = profile_topology(sensor.profile or "kinect_v2")
    return Scenario(name="drawn", description="drawn by scenarios.testing.strategies", seed=draw(seed),
                    subject=draw(subjects(topology, patients=patients)), rig=draw(rig if rig is not None else rigs()),
                    session=draw(motion if motion is not None else motions()), sensors=sensor)
