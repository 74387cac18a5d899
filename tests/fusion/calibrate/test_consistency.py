"""Cycle consistency of pair edges: detection and down-weighting of an edge that disagrees."""

import numpy as np
import pytest
from hypothesis import given, settings

from fusion.calibrate.consistency import EdgeCheck, check_cycles, down_weight
from fusion.calibrate.edges import PairEdge
from fusion.calibrate.rig_graph import chain_to_reference, shortest_path
from fusion.errors import BadInputError
from fusion.transforms import compose, from_rotvec, invert, transform_difference
from tests.strategies import seeds, transforms


def _rig(rng, n=6):
    names = [f"cam{i}" for i in range(n)]
    T = {m: from_rotvec(rng.normal(size=3), rng.normal(size=3)) for m in names}
    return names, {m: compose(invert(T["cam0"]), t) for m, t in T.items()}


def _edges(names, truth, rng, pairs, rot_std=0.2, trans_std=0.003):
    """Edges perturbed with Gaussian errors of the stated per-axis std [deg, m]."""
    out = {}
    for a, b in pairs:
        T_a_b = compose(invert(truth[a]), truth[b])
        noise = from_rotvec(rng.normal(0, np.radians(rot_std), 3), rng.normal(0, trans_std, 3))
        out[(a, b)] = PairEdge.from_std(compose(T_a_b, noise), rot_std, trans_std)
    return out


def _ring_pairs(names, chords=()):
    return [(names[i], names[(i + 1) % len(names)]) for i in range(len(names))] + list(chords)


def test_a_single_cycle_cannot_name_its_wrong_edge_but_is_down_weighted_once():
    rng = np.random.default_rng(11)
    names, truth = _rig(rng, 4)
    edges = _edges(names, truth, rng, _ring_pairs(names))
    bad = edges[("cam1", "cam2")]
    edges[("cam1", "cam2")] = PairEdge(compose(bad.T_a_b, from_rotvec([0, 0.1, 0], [0.08, 0.0, 0.0])),
                                       bad.information)
    _, checks = down_weight(edges)
    assert all(c.z > 3 for c in check_cycles(edges))  # every edge closes the same, only, cycle
    assert sum(c.distrusted for c in checks) >= 1


def test_a_wrong_ring_edge_is_the_only_one_distrusted():
    """A ring with loose chords (skeleton-like, 1 deg / 3 cm) at every camera: one wrong neighbour edge."""
    rng = np.random.default_rng(11)
    names, truth = _rig(rng)
    edges = _edges(names, truth, rng, _ring_pairs(names))
    edges |= {k: PairEdge.from_std(e.T_a_b, 1.0, 0.03)
              for k, e in _edges(names, truth, rng, [("cam1", "cam4"), ("cam2", "cam5"), ("cam0", "cam3")], 1.0,
                                 0.03).items()}
    bad = edges[("cam2", "cam3")]
    edges[("cam2", "cam3")] = PairEdge(compose(bad.T_a_b, from_rotvec([0, 0.18, 0], [0.09, 0.0, 0.0])),
                                       bad.information)
    weighted, checks = down_weight(edges)
    assert [c.key for c in checks if c.distrusted] == [("cam2", "cam3")]
    worst = next(c for c in checks if c.key == ("cam2", "cam3"))
    assert worst.z > 3 and 0 < worst.weight < 1 and worst.path[0] == "cam2" and worst.path[-1] == "cam3"
    assert np.allclose(weighted[("cam2", "cam3")].information, bad.information * worst.weight)
    # chaining now avoids the bad edge: cam3 lands within the chords' few centimetres of the truth
    _, dist = transform_difference(chain_to_reference(weighted, "cam0")["cam3"], truth["cam3"])
    _, dist_before = transform_difference(chain_to_reference(edges, "cam0")["cam3"], truth["cam3"])
    assert dist < 0.04 and dist_before > 0.08


def test_a_wrong_edge_among_chords_is_found_worst_first():
    rng = np.random.default_rng(5)
    names, truth = _rig(rng)
    edges = _edges(names, truth, rng, _ring_pairs(names, [("cam0", "cam3"), ("cam1", "cam4"), ("cam2", "cam5")]))
    bad = edges[("cam0", "cam3")]
    edges[("cam0", "cam3")] = PairEdge(compose(bad.T_a_b, from_rotvec([0.2, 0, 0], [0, 0.2, 0])), bad.information)
    _, checks = down_weight(edges)
    assert {c.key for c in checks if c.distrusted} == {("cam0", "cam3")}


@settings(max_examples=15, deadline=None)
@given(seeds)
def test_consistent_noise_is_trusted(seed):
    """Edges whose errors are within their own small uncertainty close their cycles: none distrusted."""
    rng = np.random.default_rng(seed)
    names, truth = _rig(rng, 5)
    edges = _edges(names, truth, rng, _ring_pairs(names), rot_std=0.05, trans_std=0.001)
    edges = {k: PairEdge.from_std(e.T_a_b, 0.5, 0.01) for k, e in edges.items()}  # claimed std >> actual
    checks = check_cycles(edges)
    assert all(c.checkable and not c.distrusted and c.weight == 1.0 for c in checks)
    assert all(c.z < 1.0 for c in checks)


@given(transforms())
def test_exact_edges_agree_exactly(T_world_cam1):
    names = ["cam0", "cam1", "cam2"]
    truth = {"cam0": np.eye(4), "cam1": T_world_cam1, "cam2": compose(T_world_cam1, from_rotvec([0, 0, 1.0], [1, 0, 0]))}
    edges = {(a, b): PairEdge.from_std(compose(invert(truth[a]), truth[b]), 1.0, 0.01) for a, b in _ring_pairs(names)}
    for c in check_cycles(edges):
        assert c.rotation_deg == pytest.approx(0.0, abs=1e-6) and c.translation_mm == pytest.approx(0.0, abs=1e-6)


def test_a_bridge_edge_cannot_be_checked():
    rng = np.random.default_rng(1)
    names, truth = _rig(rng, 4)
    edges = _edges(names, truth, rng, [("cam0", "cam1"), ("cam1", "cam2"), ("cam2", "cam0"), ("cam2", "cam3")])
    checks = {c.key: c for c in check_cycles(edges)}
    assert not checks[("cam2", "cam3")].checkable and not checks[("cam2", "cam3")].distrusted
    assert checks[("cam0", "cam1")].checkable


def test_shortest_path_runs_through_certain_edges():
    I = np.eye(4)
    edges = {("a", "b"): PairEdge.from_std(I, 0.1, 0.001), ("b", "c"): PairEdge.from_std(I, 0.1, 0.001),
             ("a", "c"): PairEdge.from_std(I, 5.0, 0.5)}
    assert shortest_path(edges, "a", "c") == ["a", "b", "c"]
    assert shortest_path(edges, "a", "a") == ["a"]


def test_bad_inputs():
    I = np.eye(4)
    edges = {("a", "b"): PairEdge(I), ("b", "c"): PairEdge(I), ("c", "a"): PairEdge(I)}
    with pytest.raises(BadInputError):
        check_cycles(edges, threshold_sigma=0.0)
    with pytest.raises(BadInputError):
        check_cycles(edges | {("b", "a"): PairEdge(I)})
    with pytest.raises(BadInputError):
        check_cycles({("a", "a"): PairEdge(I)})
    with pytest.raises(BadInputError):
        EdgeCheck(("a", "b"), 0.0, 0.0, 0.0, (), False, 0.0)
