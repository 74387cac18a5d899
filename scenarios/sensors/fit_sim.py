"""Refine a fitted profile's bone behaviour by simulating a scenario with the recordings' geometry.

The analytic fit (:mod:`scenarios.sensors.fit`) predicts the bone-length spread from the jitter and
wobble alone, but in the model a static per-joint bias, outliers and occlusion also change bone
lengths as the limbs move. So the one parameter the bone spread fixes (the bone rigidity for
multi-camera fits, the wobble time constant for single-camera fits) is searched by bisection until the
simulated spread of a stand-in scenario (same camera geometry, scripted movements) matches the
measured one (geometric mean over upper arm and forearm). Only the fitting recordings' statistics
are used; held-out recordings stay out.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from fusion.merge.sensor_stats import sensor_stats
from scenarios.config import Scenario
from scenarios.runner import build_simulation
from scenarios.sensors.fit import FitResult, wobble_variance_factor
from sim.sensor_profile import SensorProfile
from sim.session import simulate_session


def simulated_bone_spread(profile: SensorProfile, scenario: Scenario) -> float:
    """Geometric mean [m] of the simulated upper-arm and forearm length spreads of ``scenario``
    simulated with ``profile`` (the scenario's seed; no bootstrap)."""
    sim = build_simulation(scenario)
    sensors = dataclasses.replace(sim.sensors, tracker=profile.tracker, clock=profile.clock)
    rec, _ = simulate_session(sim.humanoid, sim.motion, sim.rig, sensors, seed=sim.session_seed,
                              person_seed=sim.person_seed, duration_s=scenario.duration_s or sim.motion.duration)
    st = sensor_stats(rec, None, n_boot=0, rng=np.random.default_rng(0))
    return float(np.sqrt(st.bone_std_mm["upper_arm"].value * st.bone_std_mm["forearm"].value) * 1e-3)


def _with_tau(fit: FitResult, tau: float) -> SensorProfile:
    dt = 1.0 / fit.profile.clock.rate_hz
    a = np.exp(-dt / tau)
    groups = {g: dataclasses.replace(n, wobble_m=float(np.sqrt(fit.d2_slow_m2[g] / wobble_variance_factor(a))))
              for g, n in fit.profile.tracker.groups.items()}
    return dataclasses.replace(fit.profile, tracker=dataclasses.replace(fit.profile.tracker, groups=groups,
                                                                          wobble_tau_s=tau))


def _with_rigidity(fit: FitResult, r: float) -> SensorProfile:
    groups = {g: dataclasses.replace(n, bone_rigidity=r) for g, n in fit.profile.tracker.groups.items()}
    return dataclasses.replace(fit.profile, tracker=dataclasses.replace(fit.profile.tracker, groups=groups))


def refine_bones(fit: FitResult, scenario: Scenario, *, steps: int = 10) -> tuple[SensorProfile, float]:
    """The fitted profile with its bone-spread parameter matched by simulation.

    Parameters
    ----------
    fit : FitResult
        The analytic fit (its measured bone spreads are the target).
    scenario : Scenario
        A scenario with the recordings' camera geometry and the profile's topology.
    steps : int
        Bisection steps (each simulates the scenario once).

    Returns
    -------
    profile : SensorProfile
        With ``bone_rigidity`` (multi-camera fit) or ``wobble_tau_s`` and the wobble sizes
        (single-camera fit) replaced, and their provenance saying so.
    simulated_m : float
        The simulated bone spread [m] it reaches.
    """
    target = float(np.sqrt(fit.bone_std_m["upper_arm"] * fit.bone_std_m["forearm"]))
    prov = dict(fit.profile.provenance)
    files = ", ".join(fit.stats)
    if fit.multi_camera:
        lo, hi = 0.0, 0.99
        for _ in range(steps):
            mid = (lo + hi) / 2
            lo, hi = (mid, hi) if simulated_bone_spread(_with_rigidity(fit, mid), scenario) > target else (lo, mid)
        profile = _with_rigidity(fit, (lo + hi) / 2)
        for g in profile.tracker.groups:
            prov[f"tracker.groups.{g.value}.bone_rigidity"] = (
                f"fitted from {files}: bisection until scenario {scenario.name} simulated with this profile has the "
                f"measured bone-length spread (geometric mean of upper arm and forearm, {target * 1e3:.1f} mm)")
    else:
        lo, hi = np.log(1.5 / fit.profile.clock.rate_hz), np.log(60.0)
        for _ in range(steps):
            mid = (lo + hi) / 2
            lo, hi = (lo, mid) if simulated_bone_spread(_with_tau(fit, float(np.exp(mid))), scenario) > target else (mid, hi)
        profile = _with_tau(fit, float(np.exp((lo + hi) / 2)))
        prov["tracker.wobble_tau_s"] = (
            f"fitted from {files}: bisection until scenario {scenario.name} simulated with this profile has the "
            f"measured bone-length spread (geometric mean of upper arm and forearm, {target * 1e3:.1f} mm), bones free")
    profile = dataclasses.replace(profile, provenance=prov)
    spread = simulated_bone_spread(profile, scenario)
    if abs(np.log(spread / target)) > np.log(1.1):
        keys = ([f"tracker.groups.{g.value}.bone_rigidity" for g in profile.tracker.groups] if fit.multi_camera
                else ["tracker.wobble_tau_s"])
        for key in keys:
            prov[key] += (f"; the search ended at its bound: the simulated spread stays "
                          f"{spread * 1e3:.1f} mm (other error sources: static bias, outliers, occlusion)")
        profile = dataclasses.replace(profile, provenance=prov)
    return profile, spread
