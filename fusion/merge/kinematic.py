"""Kinematic fusion: one articulated skeleton per subject fitted to every camera's measurements.

Model. The topology's joint tree with one rigid bone per (parent, child) pair: joint positions are
``p_j(t) = r(t) + sum_{b on the path to j} L_b u_b(t)`` with the root position ``r`` (3), unit bone
directions ``u_b`` (2 degrees of freedom each) and bone lengths ``L_b`` estimated once per session
(:func:`bone_lengths`: the median length over frames where both ends are reliably measured, left
and right instances averaged). The bone directions are the chain's joint coordinates.

Data. Every camera's measurement of a joint (back-facing skeletons relabelled first) counts with the
weight ``w = w_state * exp(-alpha^2 / gamma_a) * w_back``: its confidence (Tracked and better 1,
Inferred ``inferred_weight``), its skeleton's frontality angle ``alpha`` (as Avg(Frontal)) and its
reliability tag (``back_weight`` for a back-facing skeleton). For a fixed model pose the weighted
squared distances to all measurements equal, up to a constant, the total weight ``W_j`` times the
squared distance to their weighted mean, so each frame fits the weighted means.

Temporal prior. Each bone direction is pulled toward its direction smoothed over time (a centred
moving average over ``smooth_window_s``) with weight ``temporal_weight * L_b^2``: a smoother over the
joint coordinates. The fit alternates: smooth the directions, then Gauss-Newton (analytic Jacobian,
all frames at once) on ``sum_j W_j |p_j - m_j|^2 + prior``.

Joint limits. The bend at a joint is the angle between the bone into it and the bone out of it (0
for a straight limb). At the elbow, wrist, knee and between the spine's two bones it is bounded
(:data:`JOINT_LIMITS`): projected Gauss-Newton, a bound-constrained least squares in which every
step is followed by the projection of the bone directions onto the bounds (a bend past its bound is
brought back onto it by turning the outer bone toward the inner one in their plane), so the fit
never leaves them. The bones carry no axial twist and no flexion axis, so only the bend's size is
limited (a hyperextended elbow or knee is a bend like any other, and the humerus and thigh turn
freely in their sockets).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import uniform_filter1d

from fusion.arrays import unit
from fusion.errors import BadInputError
from fusion.merge.methods import (
    MergedSkeleton,
    MergeMethod,
    MergeParams,
    Reliability,
    frontality,
    merge,
)
from fusion.merge.views import CameraViews, unflip_back_facing
from fusion.topology import Landmark, Topology, TrackingState


@dataclass(frozen=True)
class JointLimit:
    """An upper bound on the bend at ``joint``: the angle between the bones ``proximal -> joint``
    and ``joint -> distal`` [deg], 0 for a straight chain."""

    proximal: Landmark
    joint: Landmark
    distal: Landmark
    max_bend_deg: float

    def __post_init__(self) -> None:
        if not 0.0 < self.max_bend_deg < 180.0:
            raise BadInputError(f"max_bend_deg must lie in (0, 180), got {self.max_bend_deg}")


def _both_sides(stems: tuple[str, str, str], max_bend_deg: float) -> tuple[JointLimit, ...]:
    return tuple(JointLimit(*(Landmark[f"{s}_{side}"] for s in stems), max_bend_deg) for side in ("LEFT", "RIGHT"))


JOINT_LIMITS: tuple[JointLimit, ...] = (
    *_both_sides(("SHOULDER", "ELBOW", "WRIST"), 155.0),
    *_both_sides(("ELBOW", "WRIST", "HAND"), 90.0),
    *_both_sides(("HIP", "KNEE", "ANKLE"), 145.0),
    JointLimit(Landmark.PELVIS, Landmark.SPINE_MID, Landmark.SPINE_SHOULDER, 60.0),
)
"""Bend bounds after the normal adult active ranges of motion of the American Academy of Orthopaedic
Surgeons (Greene & Heckman, *The Clinical Measurement of Joint Motion*, AAOS 1994), widened by 5-10
degrees so that a tracker's noise at the end of a normal range is not clipped (the humanoid's
coordinate ranges, ``sim/joint_limits.py``, take the same values): elbow flexion 150 -> 155; wrist
flexion 80 / extension 70 -> 90; knee flexion 135 -> 145; the spine's bend between its lower and upper
bone, thoracolumbar flexion 80 with lateral flexion 35 spread over the two bones -> 60."""


@dataclass(frozen=True)
class KinematicOptions:
    """Constants of the kinematic fit (see the module docstring).

    Attributes
    ----------
    gamma_a : frontality weight scale [rad^2] (Avg(Frontal)'s default).
    inferred_weight : weight of an Inferred measurement relative to a Tracked one.
    back_weight : weight of a measurement from a back-facing skeleton.
    temporal_weight : weight of the temporal prior per bone, relative to one unit-weight joint [1/m^2 * m^2].
    smooth_window_s : width of the moving average of the bone directions [s].
    iterations : smoothing and Gauss-Newton rounds.
    gauss_newton_steps : Gauss-Newton steps per round.
    tolerance_mm : a frame counts as converged when its last step moves no joint more than this [mm].
    limits : bend bounds (:class:`JointLimit`); those whose bones the topology lacks are skipped; an
        empty tuple switches the limits off.
    """

    gamma_a: float = MergeParams().gamma_a
    inferred_weight: float = 0.2
    back_weight: float = 0.05
    temporal_weight: float = 0.5
    smooth_window_s: float = 0.2
    iterations: int = 2
    gauss_newton_steps: int = 5
    tolerance_mm: float = 1.0
    limits: tuple[JointLimit, ...] = JOINT_LIMITS

    def __post_init__(self) -> None:
        for name in ("gamma_a", "inferred_weight", "back_weight"):
            if not getattr(self, name) > 0:
                raise BadInputError(f"{name} must be positive, got {getattr(self, name)}")
        if not all(isinstance(lim, JointLimit) for lim in self.limits):
            raise BadInputError("limits must be JointLimit values")
        for name in ("temporal_weight", "smooth_window_s", "tolerance_mm"):
            if not (np.isfinite(getattr(self, name)) and getattr(self, name) >= 0):
                raise BadInputError(f"{name} must be finite and >= 0, got {getattr(self, name)}")
        if self.iterations < 1 or self.gauss_newton_steps < 1:
            raise BadInputError("iterations and gauss_newton_steps must be at least 1")


@dataclass(frozen=True, eq=False)
class KinematicFit:
    """Result of :func:`fit_kinematic`.

    Attributes
    ----------
    merged : the fitted skeleton (NaN where no camera measured the joint, like the merging methods).
    bone_lengths : (B,) [m] per bone of ``topology.bones``.
    residual_mm : (T,) weighted RMS distance [mm] of the fitted joints from the weighted measurements.
    step_mm : (T,) bound on the joint displacement [mm] of the last Gauss-Newton step per frame.
    converged : (T,) bool, ``step_mm`` is below ``KinematicOptions.tolerance_mm``.
    at_limit : (T,) int, number of bend bounds the fitted pose rests on (where the measurements pull
        past a joint limit).
    """

    merged: MergedSkeleton
    bone_lengths: np.ndarray
    residual_mm: np.ndarray
    step_mm: np.ndarray
    converged: np.ndarray
    at_limit: np.ndarray


def measurement_targets(views: CameraViews, options: KinematicOptions = KinematicOptions()
                        ) -> tuple[np.ndarray, np.ndarray]:
    """Per joint and frame the total weight (T, J) and the weighted mean (T, J, 3) [m] of every
    camera's measurements (weights in the module docstring); weight 0 and NaN where none."""
    v = unflip_back_facing(views)
    alpha = frontality(v)
    alpha = np.where(np.isnan(alpha), MergeParams().unknown_frontality_rad, alpha)
    w_state = np.where(v.states >= TrackingState.TRACKED, 1.0,
                       np.where(v.states == TrackingState.INFERRED, options.inferred_weight, 0.0))
    w = w_state * (np.exp(-alpha**2 / options.gamma_a) * np.where(v.back_facing, options.back_weight, 1.0))[..., None]
    W = w.sum(axis=0)
    num = np.einsum("ctj,ctjk->tjk", w, np.nan_to_num(v.positions))
    with np.errstate(invalid="ignore", divide="ignore"):
        target = num / W[..., None]
    return W, np.where((W > 0)[..., None], target, np.nan)


def bone_lengths(positions: np.ndarray, reliable: np.ndarray, topology: Topology) -> np.ndarray:
    """(B,) bone lengths [m] of ``topology.bones``: the median over frames where both ends are
    ``reliable`` (T, J) bool (else over all frames with both ends) of |p_child - p_parent| in
    ``positions`` (T, J, 3), left and right instances averaged (a bone never measured takes its
    mirror's length: a hand a tracker never reported on one side).

    Raises
    ------
    BadInputError
        A bone and its mirror are never measured.
    """
    bones = topology.bones
    length = np.linalg.norm(positions[:, bones[:, 1]] - positions[:, bones[:, 0]], axis=-1)
    both = reliable[:, bones[:, 0]] & reliable[:, bones[:, 1]]
    L = np.full(len(bones), np.nan)
    for b in range(len(bones)):
        x = length[both[:, b], b]
        x = x[np.isfinite(x)] if np.isfinite(x).any() else length[np.isfinite(length[:, b]), b]
        if x.size:
            L[b] = np.median(x)
    key = {(int(p), int(c)): k for k, (p, c) in enumerate(bones)}
    mirror = topology.mirror
    twin = np.array([key.get((int(mirror[p]), int(mirror[c])), k) for k, (p, c) in enumerate(bones)])
    L = np.where(np.isnan(L), L[twin], L)
    missing = np.flatnonzero(np.isnan(L))
    if missing.size:
        names = ", ".join(f"{topology.joints[bones[b, 0]]}-{topology.joints[bones[b, 1]]}" for b in missing)
        raise BadInputError(f"bone(s) {names} (and their mirrors) are never measured: the kinematic fit needs every "
                            "bone seen at least once; fuse with --fit merge instead")
    return 0.5 * (L + L[twin])


def _path_matrix(topology: Topology) -> np.ndarray:
    """(J, B) float: 1 where bone b lies on the path from the root to joint j."""
    bones = topology.bones
    bone_of_child = {int(c): k for k, (_, c) in enumerate(bones)}
    A = np.zeros((topology.n_joints, len(bones)))
    for j in range(topology.n_joints):
        k = j
        while k in bone_of_child:
            A[j, bone_of_child[k]] = 1.0
            k = int(topology.parents[k])
    return A


def _tangent_basis(u: np.ndarray) -> np.ndarray:
    """(..., 3, 2) two unit vectors orthogonal to unit ``u`` (..., 3) and to each other."""
    not_parallel = np.where((np.abs(u[..., 0]) < 0.9)[..., None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    e1 = unit(np.cross(u, not_parallel))
    return np.stack([e1, np.cross(u, e1)], axis=-1)


def _fill_directions(u: np.ndarray) -> np.ndarray:
    """(T, B, 3) unit directions with NaN frames filled from the nearest earlier (else later) frame,
    and bones never seen pointing down (-z)."""
    T = u.shape[0]
    ok = np.isfinite(u).all(-1)
    idx = np.where(ok, np.arange(T)[:, None], -1)
    prev = np.maximum.accumulate(idx, axis=0)
    first = np.where(ok.any(0), ok.argmax(0), 0)
    src = np.where(prev >= 0, prev, first[None, :])
    out = np.take_along_axis(u, src[..., None], axis=0)
    return np.where(np.isfinite(out), out, [0.0, 0.0, -1.0])


def limit_bones(topology: Topology, limits: tuple[JointLimit, ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bone pairs of the bend bounds that ``topology`` has, proximal joints first: (K,) index of the
    bone into the joint, (K,) of the bone out of it (both into ``topology.bones``) and (K,) bounds [rad]."""
    key = {(int(p), int(c)): k for k, (p, c) in enumerate(topology.bones)}
    rows = []
    for lim in limits:
        a, j, b = (topology.index(lm) for lm in (lim.proximal, lim.joint, lim.distal))
        if (a, j) in key and (j, b) in key:
            rows.append((key[a, j], key[j, b], np.radians(lim.max_bend_deg)))
    if not rows:
        return np.zeros(0, int), np.zeros(0, int), np.zeros(0)
    depth = _path_matrix(topology).sum(axis=1)
    rows.sort(key=lambda row: depth[topology.bones[row[0], 1]])
    b_in, b_out, bound = map(np.array, zip(*rows))
    return b_in.astype(int), b_out.astype(int), bound


def bend_rad(u: np.ndarray, b_in: np.ndarray, b_out: np.ndarray) -> np.ndarray:
    """(T, K) bend [rad] between unit bone directions ``u`` (T, B, 3) of the bones ``b_in`` and ``b_out`` (K,)."""
    cos = np.einsum("tki,tki->tk", u[:, b_in], u[:, b_out])
    return np.arccos(np.clip(cos, -1.0, 1.0))


def project_limits(u: np.ndarray, b_in: np.ndarray, b_out: np.ndarray, bound: np.ndarray) -> np.ndarray:
    """(T, B, 3) unit bone directions ``u`` with every bend past its bound (:func:`limit_bones`, in
    proximal-to-distal order) brought onto it: the outer bone turned toward the inner one in their
    common plane (any plane when they are antiparallel)."""
    u = u.copy()
    for i, o, lim in zip(b_in, b_out, bound):
        cos = np.einsum("ti,ti->t", u[:, i], u[:, o])
        past = cos < np.cos(lim)
        if not past.any():
            continue
        normal = u[:, o] - cos[:, None] * u[:, i]
        norm = np.linalg.norm(normal, axis=-1, keepdims=True)
        normal = np.where(norm > 1e-9, normal / np.maximum(norm, 1e-12), _tangent_basis(u[:, i])[..., 0])
        u[past, o] = (np.cos(lim) * u[:, i] + np.sin(lim) * normal)[past]
    return u


def fit_kinematic(views: CameraViews, options: KinematicOptions = KinematicOptions()) -> KinematicFit:
    """Fit one articulated skeleton to every camera's measurements (see the module docstring).

    Parameters
    ----------
    views : C cameras, T frames, J joints in the world frame.
    options : weights, temporal prior, iterations.

    Returns
    -------
    KinematicFit
        ``merged`` (T, J, 3) [m] with the Avg(Frontal) merge's reliability classes, bone lengths,
        residuals, the last step size, convergence and the bend bounds it rests on per frame.
    """
    if not isinstance(views, CameraViews):
        raise BadInputError(f"fit_kinematic needs CameraViews, got {type(views).__name__}")
    topo = views.topology
    start = merge(views, MergeMethod.AVG_FRONTAL, MergeParams(gamma_a=options.gamma_a))
    W, m = measurement_targets(views, options)
    L = bone_lengths(m, start.reliability == Reliability.HIGH, topo)
    A = _path_matrix(topo)
    bones = topo.bones
    root = int(np.flatnonzero(np.asarray(topo.parents) == -1)[0])
    T, B = W.shape[0], len(bones)
    u = _fill_directions(unit(start.positions[:, bones[:, 1]] - start.positions[:, bones[:, 0]]))
    r = start.positions[:, root]
    r = np.where(np.isfinite(r), r, np.nanmean(m, axis=1))
    r = np.where(np.isfinite(r), r, 0.0)
    mz = np.nan_to_num(m)
    S = (A.T[None] * W[:, None, :]) @ A  # (T, B, B) sum of the weights of the joints below both bones
    S2 = np.repeat(np.repeat(S, 2, axis=1), 2, axis=2)  # per tangent coordinate
    WA = W @ A  # (T, B)
    dt = np.median(np.diff(views.times)) if T > 1 else 1.0
    window = max(1, int(round(options.smooth_window_s / dt)) | 1)
    lam = options.temporal_weight * L**2
    b_in, b_out, bound = limit_bones(topo, options.limits)
    u = project_limits(u, b_in, b_out, bound)
    step = np.full(T, np.inf)

    def positions(r: np.ndarray, u: np.ndarray) -> np.ndarray:
        return r[:, None] + A @ (L[:, None] * u)

    for _ in range(options.iterations):
        prior = unit(uniform_filter1d(u, window, axis=0, mode="nearest")) if window > 1 else u
        for _ in range(options.gauss_newton_steps):
            E = _tangent_basis(u)  # (T, B, 3, 2)
            LE = L[None, :, None, None] * E
            resid = positions(r, u) - mz  # (T, J, 3); weight W zeroes the unmeasured
            wres = W[..., None] * resid
            g_r = wres.sum(axis=1)
            g_b = ((A.T @ wres)[..., None] * LE).sum(axis=2) + ((lam[None, :, None] * (u - prior))[..., None] * E).sum(axis=2)
            n = 3 + 2 * B
            H = np.zeros((T, n, n))
            H[:, :3, :3] = W.sum(axis=1)[:, None, None] * np.eye(3)
            M = np.swapaxes(LE, 2, 3).reshape(T, 2 * B, 3)  # rows: tangent coordinates, columns: x y z
            H_rb = np.swapaxes(WA.repeat(2, axis=1)[..., None] * M, 1, 2)
            H[:, :3, 3:] = H_rb
            H[:, 3:, :3] = np.swapaxes(H_rb, 1, 2)
            H_bb = S2 * (M @ np.swapaxes(M, 1, 2))
            H_bb[:, np.arange(2 * B), np.arange(2 * B)] += np.repeat(lam, 2)[None] + 1e-9
            H[:, 3:, 3:] = H_bb
            H[:, np.arange(3), np.arange(3)] += 1e-9
            delta = -np.linalg.solve(H, np.concatenate([g_r, g_b.reshape(T, 2 * B)], axis=1)[..., None])[..., 0]
            r = r + delta[:, :3]
            turn = (E @ delta[:, 3:].reshape(T, B, 2, 1))[..., 0]
            u = project_limits(unit(u + turn), b_in, b_out, bound)
            step = np.linalg.norm(delta[:, :3], axis=-1) + (L[None] * np.linalg.norm(turn, axis=-1)).sum(axis=1)
    p = positions(r, u)
    measured = start.reliability > Reliability.NONE
    p[~measured] = np.nan
    with np.errstate(invalid="ignore", divide="ignore"):
        residual = np.sqrt((W * np.sum((p - mz) ** 2, axis=-1)).sum(1, where=measured) / W.sum(1, where=measured)) * 1e3
    at_limit = (bend_rad(u, b_in, b_out) > bound - 1e-6).sum(axis=1)
    merged = MergedSkeleton(views.times, p, start.reliability, start.n_cameras, np.full(start.n_cameras.shape, -1))
    return KinematicFit(merged, L, residual, step * 1e3, step * 1e3 < options.tolerance_mm, at_limit)
