"""The public strategies draw scenarios the simulator accepts, matching sensor and topology."""

from __future__ import annotations

import dataclasses
import math
import tomllib

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from scenarios.config import check_scenario, scenario_from_dict, scenario_toml
from scenarios.testing import strategies as mb


@settings(max_examples=60, deadline=None)
@given(mb.scenarios())
def test_drawn_scenarios_are_valid_and_round_trip(scenario):
    check_scenario(scenario)
    back = scenario_from_dict(tomllib.loads(scenario_toml(scenario)))
    assert back == scenario
    assert scenario.subject.topology == mb.profile_topology(scenario.sensors.profile)


@settings(max_examples=40, deadline=None)
@given(st.integers(2, 6).flatmap(lambda n: st.tuples(st.just(n), mb.rigs(n, n))))
def test_rigs_have_the_asked_camera_count(drawn):
    n, rig = drawn
    count = len(rig.camera) if rig.camera else len(rig.angles_deg)
    assert count == n


@settings(max_examples=30, deadline=None)
@given(mb.ring_rigs(2, 4, arc_deg=(60.0, 90.0)))
def test_arcs_face_the_subject(rig):
    assert max(abs(a) for a in rig.angles_deg) <= 45.0 + 1e-9
    assert math.isclose(rig.angles_deg[-1] - rig.angles_deg[0], 2 * max(abs(a) for a in rig.angles_deg))


def test_motions_with_clips_replay_them():
    clips = ["a.c3d", "b.trc"]
    seen = set()

    @settings(max_examples=40, deadline=None, database=None)
    @given(mb.motions(clips=clips, max_items=3))
    def draw(segments):
        assert segments[1].kind.value == "calibration_turn"
        seen.update(s.replay.source for s in segments if s.replay is not None)

    draw()
    assert seen <= set(clips) and seen


def test_noise_scale_and_flips_reach_the_tracker():
    from scenarios import api

    base = api.scenario("fma_2cam", seed=1, duration_s=25)
    quiet = base.replace(sensors=dataclasses.replace(base.sensors, noise_scale=0.25, flips=False))
    a, b = api.simulate(base), api.simulate(quiet)

    def jitter(session):
        p = session.recording.cameras[0].skeleton.positions
        return float(np.nanmedian(np.linalg.norm(np.diff(p, axis=0), axis=-1)))

    assert jitter(b) < jitter(a)
    assert not any(c.flipped.any() for c in b.truth.cameras) and any(c.flipped.any() for c in a.truth.cameras)
