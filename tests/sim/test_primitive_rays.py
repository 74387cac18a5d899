"""The compiled primitive ray caster against ``mujoco.mj_multiRay`` on random scenes and rays."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sim.raycast import RayBatchCaster, cast_rays, primitive_geoms

TYPES = ("sphere", "capsule", "ellipsoid", "cylinder", "box")
TIE_M = 1e-9  # two geoms this close along a ray: either may be reported first


def _scene(geoms: list[tuple[str, np.ndarray, np.ndarray, np.ndarray, int, float]], extra: str = "") -> mujoco.MjModel:
    """MJCF world of geoms (type, position, size (3,), quaternion, group, alpha)."""
    body = "".join(
        f'<geom type="{t}" pos="{p[0]} {p[1]} {p[2]}" size="{s[0]} {s[1]} {s[2]}" quat="{q[0]} {q[1]} {q[2]} {q[3]}" '
        f'group="{g}" rgba="1 1 1 {a}"/>'
        for t, p, s, q, g, a in geoms
    )
    return mujoco.MjModel.from_xml_string(f"<mujoco><worldbody>{body}{extra}</worldbody></mujoco>")


def _reference(model, data, origin, dirs, group, cutoff):
    n = len(dirs)
    gid, dist, normal = np.empty(n, np.int32), np.empty(n), np.empty(3 * n)
    mujoco.mj_multiRay(model, data, origin, dirs.ravel(), group, 1, -1, gid, dist, normal, n, cutoff)
    gid[dist > cutoff] = -1  # mj_multiRay's cutoff only culls geoms; it may report farther hits
    return gid, dist, normal.reshape(n, 3)


def _agree(model, data, origin, dirs, group, cutoff=mujoco.mjMAXVAL):
    hits = cast_rays(model, data, origin, dirs, geomgroup=group, cutoff_m=cutoff)
    gid, dist, normal = _reference(model, data, origin, dirs, group, cutoff)
    hit = gid >= 0
    assert np.array_equal(hits.hit, hit)
    np.testing.assert_allclose(hits.dist[hit], dist[hit], rtol=0, atol=TIE_M)
    same = hits.geom_id == gid
    assert np.all(same | (np.abs(hits.dist - dist) < TIE_M))  # another geom only on a tie
    np.testing.assert_allclose(hits.normal_world[same & hit], normal[same & hit], atol=1e-6)
    return hits


geom = st.tuples(
    st.sampled_from(TYPES),
    st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3).map(np.array),
    st.lists(st.floats(0.02, 0.5), min_size=3, max_size=3).map(np.array),
    st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4).map(np.array).filter(lambda q: np.linalg.norm(q) > 0.1),
    st.sampled_from([0, 1, 2, 7]),
    st.sampled_from([1.0, 1.0, 1.0, 0.0]),
)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(geoms=st.lists(geom, min_size=1, max_size=8), seed=st.integers(0, 2**32 - 1),
       inside=st.booleans(), groups=st.sampled_from([None, (1, 1, 1, 0, 0, 0), (0, 1, 0, 0, 0, 1)]))
def test_first_hits_match_mujoco(geoms, seed, inside, groups):
    """Same geoms, distances and normals as mj_multiRay, origins outside or inside a geom."""
    model = _scene(geoms)
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    group = None if groups is None else np.array(groups, dtype=np.uint8)
    rng = np.random.default_rng(seed)
    origin = data.geom_xpos[0] if inside else rng.uniform(-3.0, 3.0, 3)
    dirs = rng.normal(size=(400, 3))
    aim = rng.choice(model.ngeom, 200)
    dirs[:200] = data.geom_xpos[aim] - origin + rng.normal(scale=0.1, size=(200, 3))  # many towards the geoms
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    assert primitive_geoms(model, group) is not None
    _agree(model, data, origin, dirs, group)
    hits = _agree(model, data, origin, dirs, group, cutoff=1.5)
    assert np.all(hits.dist[hits.hit] <= 1.5)


def test_scene_with_a_plane_falls_back_to_mujoco():
    model = _scene([("sphere", np.array([2.0, 0, 1]), np.full(3, 0.3), np.array([1.0, 0, 0, 0]), 0, 1.0)],
                   extra='<geom type="plane" size="5 5 0.1"/>')
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    assert primitive_geoms(model, None) is None
    assert primitive_geoms(model, np.array([1, 0, 0, 0, 0, 0], np.uint8)) is None
    dirs = np.array([[1.0, 0, 0], [0.6, 0, -0.8]])
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    hits = _agree(model, data, np.array([0.0, 0, 1]), dirs, None)
    assert list(hits.geom_id) == [0, 1]


@pytest.mark.parametrize("group", [None, (0, 1, 0, 0, 0, 0)])
def test_batch_caster_matches_cast_rays(group):
    geoms = [("capsule", np.array([1.0, 0.2, 1.0]), np.array([0.1, 0.4, 0]), np.array([1.0, 0.3, 0, 0]), 1, 1.0),
             ("box", np.array([2.0, -0.2, 1.0]), np.array([0.2, 0.3, 0.4]), np.array([1.0, 0, 0.2, 0]), 1, 1.0)]
    model = _scene(geoms)
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    rng = np.random.default_rng(4)
    dirs = np.array([1.5, 0.0, 1.0]) + rng.normal(scale=0.5, size=(300, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    caster = RayBatchCaster(model, len(dirs), geomgroup=group)
    geom_id, dist = caster.cast(data, np.zeros(3), dirs, 3.0)
    hits = cast_rays(model, data, np.zeros(3), dirs, geomgroup=group, cutoff_m=3.0)
    assert np.array_equal(geom_id, hits.geom_id) and np.array_equal(dist, hits.dist)
    assert 50 < np.count_nonzero(hits.hit) < 250
