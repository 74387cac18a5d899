"""The Orbbec Femto profiles: they load and validate, every value has a provenance that cites Orbbec's
pages or says it is carried over from the fitted Azure Kinect profile, the depth model keeps within
the published accuracy bound, and a short simulation with them runs."""

from __future__ import annotations

import dataclasses
import tomllib

import numpy as np
import pytest

from fusion.topology import K4ABT
from scenarios.config import load_scenario
from scenarios.runner import simulate
from sim.depth_noise import sigma_axial_mm
from sim.sensor_population import population_keys
from sim.sensor_profile import (
    builtin_profiles,
    load_profile,
    parameter_keys,
    profile_from_dict,
    profile_to_toml,
)

ORBBEC = ("orbbec_femto_bolt", "orbbec_femto_mega")

RANDOM_ERROR_BOUND_MM = 17.0
"""Published random depth error bound (std) of the Femto depth camera [mm]."""


@pytest.mark.parametrize("name", ORBBEC)
def test_profile_loads_with_a_provenance_for_every_value(name) -> None:
    p = load_profile(name)
    assert name in builtin_profiles() and p.name == name and p.topology == K4ABT
    keys = parameter_keys(p.tracker) + population_keys(p.population)
    assert set(p.provenance) == set(keys)
    for k in keys:
        source = p.provenance[k]
        assert "orbbec.com" in source or "azure_kinect" in source, k
    assert profile_from_dict(tomllib.loads(profile_to_toml(p))) == p


@pytest.mark.parametrize("name", ORBBEC)
def test_tracker_is_the_fitted_azure_one(name) -> None:
    p, azure = load_profile(name), load_profile("azure_kinect")
    assert p.tracker == azure.tracker and p.population == azure.population
    assert all("copied in value from the fitted azure_kinect profile" in p.provenance[k]
               for k in p.provenance if k.startswith(("tracker.", "population.")))
    assert p.depth == azure.depth  # same ToF model, within the published bounds
    assert p.clock.rate_hz == 30.0
    assert dataclasses.replace(p.clock, rate_hz=azure.clock.rate_hz) == azure.clock


@pytest.mark.parametrize("name", ORBBEC)
def test_depth_noise_within_published_bound(name) -> None:
    depth = load_profile(name).depth
    z = np.linspace(0.5, 3.86, 50)  # NFOV unbinned operating range [m]
    sigma = sigma_axial_mm(z, np.zeros_like(z), depth)
    assert np.all(sigma > 0) and np.all(sigma <= RANDOM_ERROR_BOUND_MM)
    assert depth.offset_mm == 0.0


def test_short_simulation_with_femto_bolt() -> None:
    sc = load_scenario("azure_2cam_45")
    sc = sc.replace(duration_s=1.0, sensors=dataclasses.replace(sc.sensors, profile="orbbec_femto_bolt",
                                                                depth_rate_hz=2.0))
    rec, truth = simulate(sc, progress=False)
    assert rec.topology == K4ABT and len(rec.cameras) == 2
    assert set(truth.T_world_cam()) == {c.name for c in rec.cameras}
    for cam in rec.cameras:
        assert cam.skeleton.n_frames >= 25 and np.isfinite(cam.skeleton.positions).any()
        assert cam.depth is not None and cam.depth.n_frames >= 1
    again, _ = simulate(sc, progress=False)
    assert np.array_equal(again.cameras[0].skeleton.positions, rec.cameras[0].skeleton.positions, equal_nan=True)
