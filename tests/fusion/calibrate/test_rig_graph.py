import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fusion.calibrate.edges import PairEdge
from fusion.calibrate.loop import LoopClosure, loop_closure, rig_loop_closure
from fusion.calibrate.rig_graph import (
    GraphLoss,
    RigSolution,
    chain_to_reference,
    optimise_pose_graph,
)
from fusion.errors import BadInputError, CalibrationError, UnknownNameError
from fusion.transforms import (
    compose,
    from_rotvec,
    invert,
    make_transform,
    to_rotvec,
    transform_difference,
)
from tests.strategies import seeds, transforms

TEST_POINTS = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.8, 0.8) for z in (2.0, 3.0)])
"""Points where a subject stands in front of a camera [m]."""


@st.composite
def rigs(draw, min_cameras=3, max_cameras=6):
    """(camera names in ring order, true T_ref_cam with the first camera as reference)."""
    n = draw(st.integers(min_cameras, max_cameras))
    T_world_cam = [draw(transforms()) for _ in range(n)]
    names = [f"cam{i}" for i in range(n)]
    return names, {name: compose(invert(T_world_cam[0]), T) for name, T in zip(names, T_world_cam)}


def _ring_edges(names, T_ref_cam, chords=(), rng=None, rot_std=0.5, trans_std=0.01):
    """Ring (and chord) edges, exact or perturbed with Gaussian errors of the given std [deg, m]."""
    pairs = [(names[i], names[(i + 1) % len(names)]) for i in range(len(names))] + list(chords)
    edges = {}
    for a, b in pairs:
        T_a_b = compose(invert(T_ref_cam[a]), T_ref_cam[b])
        if rng is not None:
            T_a_b = compose(T_a_b, from_rotvec(rng.normal(0, np.radians(rot_std), 3), rng.normal(0, trans_std, 3)))
        edges[(a, b)] = PairEdge.from_std(T_a_b, rot_std, trans_std)
    return edges


def _cost(edges, T_ref_cam):
    """Half the summed squared Mahalanobis norms of the edge errors (the pose graph's objective)."""
    total = 0.0
    for (a, b), edge in edges.items():
        rv, t = to_rotvec(compose(invert(edge.T_a_b), invert(T_ref_cam[a]), T_ref_cam[b]))
        e = np.r_[rv, t]
        total += 0.5 * e @ edge.information @ e
    return total


def _max_error(T_est, T_true):
    rot, dist = zip(*(transform_difference(T_est[n], T_true[n]) for n in T_true))
    return max(rot), max(dist)


@given(rigs(min_cameras=2), st.data())
def test_chaining_exact_edges_reproduces_the_truth(rig, data):
    names, truth = rig
    # A random spanning tree, edges pointing either way, plus a few extra exact edges.
    edges = {}
    for i in range(1, len(names)):
        j = data.draw(st.integers(0, i - 1))
        a, b = (names[i], names[j]) if data.draw(st.booleans()) else (names[j], names[i])
        edges[(a, b)] = PairEdge(compose(invert(truth[a]), truth[b]))
    reference = data.draw(st.sampled_from(names))
    chained = chain_to_reference(edges, reference)
    expected = {n: compose(invert(truth[reference]), truth[n]) for n in names}
    assert set(chained) == set(names)
    rot, dist = _max_error(chained, expected)
    assert rot < 1e-6 and dist < 1e-9


def test_chaining_takes_the_most_certain_path():
    truth = {n: make_transform(np.eye(3), [i, 0, 0]) for i, n in enumerate("abcd")}

    def edge(a, b, std_m, bias_m=0.0):
        T_a_b = compose(invert(truth[a]), truth[b], make_transform(np.eye(3), [bias_m, 0, 0]))
        return PairEdge.from_std(T_a_b, 1.0, std_m)

    # the precise 2-hop path a-b-c beats a-c direct (1 hop, imprecise, biased by 5 cm) ...
    edges = {("a", "b"): edge("a", "b", 0.001), ("b", "c"): edge("b", "c", 0.001),
             ("a", "c"): edge("a", "c", 0.5, 0.05)}
    assert chain_to_reference(edges, "a")["c"][0, 3] == pytest.approx(2.0)
    # ... and with equally certain edges the fewest hops win.
    edges = {("a", "b"): edge("a", "b", 0.01), ("b", "c"): edge("b", "c", 0.01),
             ("a", "c"): edge("a", "c", 0.01, 0.05)}
    assert chain_to_reference(edges, "a")["c"][0, 3] == pytest.approx(2.05)
    # Two 2-hop paths to d: through b (precise, biased 1 cm) beats through c (imprecise).
    edges = {("a", "b"): edge("a", "b", 0.001), ("b", "d"): edge("b", "d", 0.001, 0.01),
             ("a", "c"): edge("a", "c", 0.1), ("c", "d"): edge("c", "d", 0.1)}
    assert chain_to_reference(edges, "a")["d"][0, 3] == pytest.approx(3.01)
    # Of two measurements of one pair, the lower variance one is used, whatever its direction.
    edges = {("a", "b"): edge("a", "b", 0.1, 0.02),
             ("b", "a"): PairEdge.from_std(make_transform(np.eye(3), [-1.0, 0, 0]), 1.0, 0.001)}
    assert chain_to_reference(edges, "a")["b"][0, 3] == pytest.approx(1.0)


def test_chaining_names_unreachable_cameras():
    edges = {("a", "b"): PairEdge(np.eye(4)), ("c", "d"): PairEdge(np.eye(4))}
    with pytest.raises(CalibrationError, match=r"\['c', 'd', 'e'\]"):
        chain_to_reference(edges, "a", cameras=["a", "b", "c", "d", "e"])
    with pytest.raises(UnknownNameError, match="available: a, b, c, d"):
        chain_to_reference(edges, "x")
    assert list(chain_to_reference({}, "solo")) == ["solo"]


def test_edge_validation():
    with pytest.raises(BadInputError):
        PairEdge(2 * np.eye(4))
    with pytest.raises(BadInputError):
        PairEdge(np.eye(4), information=-np.eye(6))
    with pytest.raises(BadInputError):
        PairEdge(np.eye(4), information=np.eye(6) + np.triu(np.ones((6, 6)), 1))
    with pytest.raises(BadInputError):
        PairEdge.from_std(np.eye(4), 0.0, 0.01)
    with pytest.raises(BadInputError):
        chain_to_reference({("a", "a"): PairEdge(np.eye(4))}, "a")
    with pytest.raises(BadInputError):
        chain_to_reference({("a", "b"): np.eye(4)}, "a")
    edge = PairEdge.from_std(np.eye(4), 1.0, 0.01)
    assert edge.variance == pytest.approx(3 * np.radians(1.0) ** 2 + 3 * 0.01**2)
    np.testing.assert_allclose(PairEdge(np.eye(4)).information, edge.information)


@given(rigs(), st.data())
def test_pose_graph_leaves_a_consistent_cycle_unchanged(rig, data):
    names, truth = rig
    chords = [(names[0], names[len(names) // 2])] if data.draw(st.booleans()) and len(names) > 3 else []
    solution = optimise_pose_graph(_ring_edges(names, truth, chords), names[0])
    assert isinstance(solution, RigSolution) and solution.converged
    rot, dist = _max_error(solution.T_ref_cam, truth)
    assert rot < 1e-6 and dist < 1e-9
    assert solution.residual_rotation_deg.max() < 1e-6 and solution.residual_translation_mm.max() < 1e-6
    assert solution.cost < 1e-16


@given(rigs(), seeds)
def test_pose_graph_reduces_the_loop_error_of_a_perturbed_cycle(rig, seed):
    names, truth = rig
    edges = _ring_edges(names, truth, rng=np.random.default_rng(seed))
    chained = chain_to_reference(edges, names[0])
    solution = optimise_pose_graph(edges, names[0])
    assert solution.converged
    before = loop_closure(edges, names, TEST_POINTS)
    after = rig_loop_closure(solution.T_ref_cam, names, TEST_POINTS)
    assert after.mean_mm < 1e-6 <= before.mean_mm
    # The chained rig is one candidate solution, so the optimum fits the edges at least as well.
    assert solution.cost == pytest.approx(_cost(edges, solution.T_ref_cam), rel=1e-9, abs=1e-12)
    assert solution.cost <= _cost(edges, chained) + 1e-12


def test_pose_graph_is_closer_to_the_truth_than_chaining_on_average():
    rng = np.random.default_rng(1)
    names = [f"cam{i}" for i in range(6)]
    chain_errors, graph_errors = [], []
    for _ in range(20):
        truth = {n: from_rotvec(rng.normal(size=3), rng.normal(size=3)) for n in names}
        truth = {n: compose(invert(truth["cam0"]), T) for n, T in truth.items()}
        edges = _ring_edges(names, truth, chords=[("cam0", "cam3"), ("cam1", "cam4")], rng=rng)
        chain_errors.append(_max_error(chain_to_reference(edges, "cam0"), truth)[1])
        graph_errors.append(_max_error(optimise_pose_graph(edges, "cam0").T_ref_cam, truth)[1])
    assert np.mean(graph_errors) < 0.8 * np.mean(chain_errors)


@given(rigs(), seeds, st.permutations(range(6)))
def test_pose_graph_does_not_depend_on_camera_names_or_edge_order(rig, seed, perm):
    names, truth = rig
    edges = _ring_edges(names, truth, chords=[(names[0], names[2])], rng=np.random.default_rng(seed))
    solution = optimise_pose_graph(edges, names[0])
    rename = {n: f"x{perm[i]}" for i, n in enumerate(names)}
    shuffled = {(rename[a], rename[b]): edges[(a, b)] for a, b in reversed(list(edges))}
    renamed = optimise_pose_graph(shuffled, rename[names[0]])
    for n in names:
        np.testing.assert_allclose(renamed.T_ref_cam[rename[n]], solution.T_ref_cam[n], atol=1e-6)


def test_pose_graph_accepts_an_initial_guess_in_any_frame():
    rng = np.random.default_rng(3)
    names = [f"cam{i}" for i in range(4)]
    truth = {n: from_rotvec(rng.normal(size=3), rng.normal(size=3)) for n in names}
    truth = {n: compose(invert(truth["cam0"]), T) for n, T in truth.items()}
    edges = _ring_edges(names, truth, rng=rng)
    gauge = from_rotvec([0.3, -1.0, 2.0], [5.0, 1.0, -2.0])
    solution = optimise_pose_graph(edges, "cam0", {n: compose(gauge, T) for n, T in truth.items()})
    default = optimise_pose_graph(edges, "cam0")
    for n in names:
        np.testing.assert_allclose(solution.T_ref_cam[n], default.T_ref_cam[n], atol=1e-6)
    np.testing.assert_array_equal(solution.T_ref_cam["cam0"], np.eye(4))
    with pytest.raises(BadInputError):
        optimise_pose_graph(edges, "cam0", {"cam0": np.eye(4)})
    with pytest.raises(BadInputError):
        optimise_pose_graph(edges, "cam0", loss="huber")


def test_robust_loss_resists_a_failed_pair():
    rng = np.random.default_rng(4)
    names = [f"cam{i}" for i in range(6)]
    truth = {n: from_rotvec(rng.normal(size=3), rng.normal(size=3)) for n in names}
    truth = {n: compose(invert(truth["cam0"]), T) for n, T in truth.items()}
    edges = _ring_edges(names, truth, chords=[("cam0", "cam2"), ("cam0", "cam3"), ("cam1", "cam4"), ("cam2", "cam5")],
                        rng=rng)
    bad = edges[("cam0", "cam3")]
    edges[("cam0", "cam3")] = PairEdge(compose(bad.T_a_b, from_rotvec([0, 0.5, 0], [0.3, 0, 0])), bad.information)
    plain = _max_error(optimise_pose_graph(edges, "cam0").T_ref_cam, truth)
    for loss in (GraphLoss.HUBER, GraphLoss.CAUCHY):
        solution = optimise_pose_graph(edges, "cam0", loss=loss)
        robust = _max_error(solution.T_ref_cam, truth)
        assert solution.converged and robust[0] < 0.2 * plain[0] and robust[1] < 0.5 * plain[1]
    worst = solution.edge_keys[int(np.argmax(solution.residual_rotation_deg))]
    assert worst == ("cam0", "cam3")  # the failed pair stands out in the residuals


def test_pose_graph_without_edges_is_the_reference_alone():
    solution = optimise_pose_graph({}, "solo")
    assert list(solution.T_ref_cam) == ["solo"] and solution.converged


@given(rigs())
def test_loop_closure_of_exact_edges_is_zero(rig):
    names, truth = rig
    result = loop_closure(_ring_edges(names, truth), names, TEST_POINTS)
    assert isinstance(result, LoopClosure)
    assert result.max_mm < 1e-6
    assert result.farthest[names[0]] == names[len(names) // 2]


@given(rigs(), seeds, st.integers(0, 5))
def test_loop_closure_does_not_depend_on_where_the_ring_starts(rig, seed, shift):
    names, truth = rig
    edges = _ring_edges(names, truth, rng=np.random.default_rng(seed))
    k = shift % len(names)
    base = loop_closure(edges, names, TEST_POINTS)
    rotated = loop_closure(edges, names[k:] + names[:k], TEST_POINTS)
    for n in names:
        assert rotated.per_camera_mm[n] == pytest.approx(base.per_camera_mm[n], rel=1e-9, abs=1e-9)
    if len(names) % 2 == 0:  # the farthest camera is the same either way round
        reverse = loop_closure(edges, names[::-1], TEST_POINTS)
        for n in names:
            assert reverse.per_camera_mm[n] == pytest.approx(base.per_camera_mm[n], rel=1e-9, abs=1e-9)


def test_loop_closure_known_value():
    """Four cameras, exact but one edge shifted 1 cm: each camera's two paths differ by that 1 cm."""
    names = ["a", "b", "c", "d"]
    truth = {n: make_transform(np.eye(3), [i, 0, 0]) for i, n in enumerate(names)}
    edges = _ring_edges(names, truth)
    edges[("a", "b")] = PairEdge(compose(edges[("a", "b")].T_a_b, make_transform(np.eye(3), [0.01, 0, 0])))
    result = loop_closure(edges, names, {n: TEST_POINTS for n in names})
    for n in names:
        assert result.per_camera_mm[n] == pytest.approx(10.0)
    assert result.mean_mm == pytest.approx(10.0)


def test_loop_closure_bad_inputs():
    names = ["a", "b", "c"]
    truth = {n: np.eye(4) for n in names}
    edges = _ring_edges(names, truth)
    with pytest.raises(BadInputError):
        loop_closure(edges, ["a", "b"], TEST_POINTS)
    with pytest.raises(BadInputError):
        loop_closure(edges, ["a", "b", "b"], TEST_POINTS)
    with pytest.raises(BadInputError):
        loop_closure({("a", "b"): edges[("a", "b")]}, names, TEST_POINTS)
    with pytest.raises(BadInputError):
        loop_closure(edges, names, {"a": TEST_POINTS})
    with pytest.raises(BadInputError):
        loop_closure(edges, names, np.zeros((0, 3)))
    with pytest.raises(BadInputError):
        rig_loop_closure({"a": np.eye(4)}, names, TEST_POINTS)
