"""Retargeting: the humanoid's coordinates fitted frame by frame to a landmark trajectory.

Inverse kinematics on MuJoCo's kinematics: for each frame, a Levenberg-Marquardt fit bounded by
:func:`sim.joint_limits.coordinate_limits` (:func:`sim.least_squares.bounded_least_squares`) minimises

- the confidence-weighted distances between the humanoid's sites ``"{topology}/{joint}"`` and the
  target joints (absent joints skipped), their Jacobian from :class:`sim.site_jacobian.SiteJacobian`;
- a smoothness term ``(x - x_previous) * smoothness_m_per_rad`` that keeps the motion continuous
  and resolves joints the landmarks leave undetermined;
- a weak pull (``prior_m_per_rad``) towards the neutral stance for coordinates no landmark
  constrains (e.g. wrist flexion without hand tips); for the shoulder it pulls the axial twist
  ``sh_rotation - sh_plane``, not the plane of elevation.

The unknowns are the coordinates of :mod:`sim.coordinates` plus the pelvis height (the replayed
motion grounds the feet again, see :meth:`sim.humanoid.Humanoid.qpos`). Each frame starts from the
previous frame's solution; the first frame from the neutral stance placed at the pelvis and turned to
face where the hips face. A nearly hanging arm (the Y-X-Y shoulder's gimbal lock, where the landmark
error hardly depends on the plane of elevation) is compared with the arm solved in closed form from
its targets, and a frame whose error jumps is fitted again from closed-form arms
(:mod:`sim.retarget_seed`). Short gaps of a joint are bridged by linear interpolation before the fit
(:func:`bridge_gaps`), longer ones are skipped. A frame whose solver failed or whose weighted RMS
residual exceeds ``max_rms_m`` is reported as not converged (``RetargetResult.failed_frames``).

Measured round trip on the humanoid's own landmarks (salute and hand lift of each arm, two of
each, 1378 frames at 30 Hz; ``tests/sim/test_retarget.py`` runs one of each): shoulder elevation
and elbow flexion within 0.17 and 0.49 degrees in every frame (median 0.002), landmarks within
1.05 mm, with either topology. The smoothness weight is what limits it: 0.02 m/rad leaves up to 1.2
degrees (the fit lags where the elbow straightens and the axial rotations of humerus and forearm
share one axis), 0.0025 m/rad 0.3. On the real samples (KIMORE, azure_2cam) going from 0.02 to
0.005 m/rad changed the median residuals per joint group by less than 1 mm or lowered them, and
raised the frame-to-frame jitter of the fitted arm angles by 0-15 % in most series.

The per-frame solver is :mod:`sim.least_squares` rather than :func:`scipy.optimize.least_squares`
(trust-region reflective), whose per-call work dominates on problems of this size (about 30
unknowns, 130 residuals, four evaluations). Against it, fitting seven real two-camera sessions
(azure_2cam, 774-1330 frames, two or three per person) ran at 900-1170 frames/s against its 300-370,
with median frame residuals within 0.08 mm of its own and no failed frame; on the test's round trip
(one motion of each kind, 866 frames) the largest elevation and flexion errors are 0.14 and 0.22
degrees (SciPy 0.13 and 0.25), landmarks within 0.84 mm (0.57). In 1 % of the frames of one
person's fast sessions the arm angles differ by tens of degrees: a hanging arm's plane of
elevation, where SciPy's own fits with four and with eight evaluations differ as much.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass

import mujoco
import numpy as np

from fusion.errors import BadInputError
from fusion.io.mocap import LandmarkTrajectory
from fusion.merge.metrics import Stats
from fusion.topology import Landmark, Topology
from sim.coordinates import COORDINATES, INDEX, ROOT
from sim.humanoid import Humanoid
from sim.joint_limits import coordinate_limits
from sim.least_squares import Solution, bounded_least_squares
from sim.retarget_seed import initial_guess, restart_guess, seed_arms
from sim.site_jacobian import SiteJacobian

K = len(COORDINATES)
_Z = K  # index of the pelvis height among the unknowns


@dataclass(frozen=True)
class RetargetOptions:
    """How to fit.

    Attributes
    ----------
    smoothness_m_per_rad : float
        Weight of the frame-to-frame change: a change of 1 rad (1 m of the root) costs as much as
        this many metres of landmark error. It pulls each frame towards the previous one, so a
        larger weight makes the fit lag behind fast or poorly constrained motion (see the module
        docstring for the measured effect).
    prior_m_per_rad : float
        Weight of the pull towards the neutral stance, same units.
    max_gap_s : float
        Gaps of a joint up to this long are bridged by interpolation, seconds.
    max_rms_m : float
        A frame with a larger weighted RMS landmark residual counts as not converged, metres. The
        default flags gross failures only: fitting a fused two-camera simulated Kinect v2 session
        (``fma_2cam``, default noise) leaves a median frame RMS of 76 mm, since the tracker's joints
        are not those of one rigid body.
    max_iterations : int
        Function evaluations per frame (the first frame gets ten times as many).
    """

    smoothness_m_per_rad: float = 0.005
    prior_m_per_rad: float = 0.002
    max_gap_s: float = 0.25
    max_rms_m: float = 0.15
    max_iterations: int = 4

    def __post_init__(self) -> None:
        for name in ("smoothness_m_per_rad", "prior_m_per_rad", "max_gap_s"):
            if not (np.isfinite(getattr(self, name)) and getattr(self, name) >= 0):
                raise BadInputError(f"{name} must be a finite number >= 0, got {getattr(self, name)}")
        if not (np.isfinite(self.max_rms_m) and self.max_rms_m > 0):
            raise BadInputError(f"max_rms_m must be positive, got {self.max_rms_m}")
        if not (isinstance(self.max_iterations, int) and self.max_iterations >= 2):
            raise BadInputError(f"max_iterations must be an int >= 2, got {self.max_iterations}")


@dataclass(frozen=True, eq=False)
class RetargetResult:
    """A fitted motion and how well it fits.

    Attributes
    ----------
    times : (T,) s, the trajectory's times.
    coords : (T, K) coordinates over :data:`sim.coordinates.COORDINATES`, metres / radians.
    pelvis_height : (T,) fitted pelvis height, metres (the replay grounds the feet instead).
    errors : (T, J) distance of each humanoid site from its target, metres; NaN where absent.
    frame_rms : (T,) confidence-weighted RMS landmark error per frame, metres.
    converged : (T,) bool, the solver ran without error and ``frame_rms <= max_rms_m`` (reaching
        ``max_iterations`` is normal: each frame starts from the previous one's solution).
    evaluations : (T,) int function evaluations per frame.
    topology : the landmarks' joint set.
    """

    times: np.ndarray
    coords: np.ndarray
    pelvis_height: np.ndarray
    errors: np.ndarray
    frame_rms: np.ndarray
    converged: np.ndarray
    evaluations: np.ndarray
    topology: Topology

    @property
    def failed_frames(self) -> np.ndarray:
        """Indices of the frames that did not converge."""
        return np.flatnonzero(~self.converged)

    def joint_stats(self) -> dict[str, Stats]:
        """Landmark error statistics per joint name (metres), joints never present left out."""
        return {j: Stats.of(self.errors[:, i]) for i, j in enumerate(self.topology.joints)
                if np.isfinite(self.errors[:, i]).any()}

    def group_errors(self) -> dict[str, np.ndarray]:
        """The finite landmark errors of each joint group (trunk, left/right arm, left/right leg),
        metres, flattened over frames and joints; groups never present left out."""
        groups = joint_groups(self.topology)
        out = {g: self.errors[:, groups == g] for g in np.unique(groups)}
        return {str(g): e[np.isfinite(e)] for g, e in out.items() if np.isfinite(e).any()}

    def group_stats(self) -> dict[str, Stats]:
        """Landmark error statistics per joint group (trunk, left/right arm, left/right leg), metres."""
        return {g: Stats.of(e) for g, e in self.group_errors().items()}


_GROUP_ROOTS = {
    Landmark.SHOULDER_LEFT: "left arm", Landmark.SHOULDER_RIGHT: "right arm",
    Landmark.HIP_LEFT: "left leg", Landmark.HIP_RIGHT: "right leg",
}


def joint_groups(topology: Topology) -> np.ndarray:
    """(J,) group name of each joint: the limb whose root (shoulder, hip) it descends from, else trunk."""
    roots = {topology.index(lm): g for lm, g in _GROUP_ROOTS.items()}
    out = []
    for j in range(topology.n_joints):
        k = j
        while k >= 0 and k not in roots:
            k = topology.parents[k]
        out.append(roots.get(k, "trunk"))
    return np.array(out)


def bridge_gaps(traj: LandmarkTrajectory, max_gap_s: float) -> LandmarkTrajectory:
    """Fill each joint's gaps of at most ``max_gap_s`` seconds by linear interpolation.

    Filled samples get half the smaller confidence of the two ends. Leading and trailing gaps
    stay absent.

    Parameters
    ----------
    traj : LandmarkTrajectory
    max_gap_s : float
        Longest gap bridged, seconds (between the last sample before and the first after).

    Returns
    -------
    LandmarkTrajectory
    """
    pos, conf, t = np.array(traj.positions), np.array(traj.confidence), traj.times
    for j in range(traj.topology.n_joints):
        present = np.flatnonzero(conf[:, j] > 0)
        if present.size < 2:
            continue
        for a, b in itertools.pairwise(present):
            if b - a > 1 and t[b] - t[a] <= max_gap_s:
                s = ((t[a + 1 : b] - t[a]) / (t[b] - t[a]))[:, None]
                pos[a + 1 : b, j] = (1 - s) * pos[a, j] + s * pos[b, j]
                conf[a + 1 : b, j] = 0.5 * min(conf[a, j], conf[b, j])
    return LandmarkTrajectory(traj.topology, t, pos, conf, traj.source)


class _Problem:
    """Residuals and Jacobians of one frame's fit on a humanoid's MuJoCo model."""

    def __init__(self, humanoid: Humanoid, topology: Topology, options: RetargetOptions) -> None:
        self.h, self.m, self.d = humanoid, humanoid.model, mujoco.MjData(humanoid.model)
        self.sites = humanoid.site_ids(topology)
        root = mujoco.mj_name2id(self.m, mujoco.mjtObj.mjOBJ_JOINT, "root")
        self.root_q, root_v = int(self.m.jnt_qposadr[root]), int(self.m.jnt_dofadr[root])
        hinges = [c for c in COORDINATES if c not in ROOT]
        self.hinge_cols = np.array([INDEX[c] for c in hinges])
        self.hinge_q = np.array([humanoid.qpos_adr[c] for c in hinges])
        dof = np.empty(K + 1, dtype=int)
        dof[self.hinge_cols] = [self.m.jnt_dofadr[mujoco.mj_name2id(self.m, mujoco.mjtObj.mjOBJ_JOINT, c)]
                                for c in hinges]
        # free joint: translation dofs are world x, y, z; the rotation dofs are body-local, and the
        # pelvis only turns about z, so local z is world z
        dof[[INDEX["root_x"], INDEX["root_y"], _Z, INDEX["root_yaw"]]] = root_v + np.array([0, 1, 2, 5])
        self.site_jacobian = SiteJacobian(self.m, self.sites, dof)  # dof: the MuJoCo dof of each unknown
        lo, hi = coordinate_limits()
        self.lower, self.upper = np.r_[lo, -np.inf], np.r_[hi, np.inf]
        # smoothness s (x - x_prev) and a diagonal prior w x add up, up to a constant, to
        # c (x - s^2 x_prev / c^2) with c^2 = s^2 + w^2: one row per unknown; the shoulder twists
        # (not diagonal) keep a row each
        s, w = options.smoothness_m_per_rad, options.prior_m_per_rad
        diag = np.full(K + 1, w)
        diag[[INDEX[c] for c in (*ROOT, *(f"sh_{k}_{side}" for k in ("plane", "rotation") for side in "lr"))]] = 0.0
        diag[_Z] = 0.0
        self.c = np.sqrt(s**2 + diag**2)
        self.pull = np.divide(s**2, self.c**2, out=np.zeros(K + 1), where=self.c > 0)
        self.twist = np.zeros((2, K + 1))
        for row, side in enumerate("lr"):
            self.twist[row, INDEX[f"sh_rotation_{side}"]], self.twist[row, INDEX[f"sh_plane_{side}"]] = w, -w
        self.parent_bodies = {side: mujoco.mj_name2id(self.m, mujoco.mjtObj.mjOBJ_BODY, f"clavicle_{side}")
                              for side in "lr"}
        self.x_prev = np.zeros(K + 1)
        self.target = np.zeros((0, 3))
        self.w = np.zeros(0)
        self.active = np.zeros(0, dtype=int)

    def pose(self, x: np.ndarray) -> None:
        q = self.d.qpos
        q[:] = self.m.qpos0
        a = self.root_q
        q[a], q[a + 1], q[a + 2] = x[INDEX["root_x"]], x[INDEX["root_y"]], x[_Z]
        yaw = x[INDEX["root_yaw"]]
        q[a + 3 : a + 7] = (np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2))
        q[self.hinge_q] = x[self.hinge_cols]
        mujoco.mj_kinematics(self.m, self.d)

    def parents(self, x: np.ndarray) -> dict[str, np.ndarray]:
        """Side -> (3, 3) world rotation of the body the shoulder hinges ride on, at ``x``."""
        self.pose(x)
        return {side: self.d.xmat[b].reshape(3, 3).copy() for side, b in self.parent_bodies.items()}

    def residuals(self, x: np.ndarray) -> np.ndarray:
        self.pose(x)
        site = self.d.site_xpos[self.sites[self.active]]
        return np.concatenate([((site - self.target) * self.w[:, None]).ravel(),
                               self.c * (x - self.pull * self.x_prev), self.twist @ x])

    def use(self, target: np.ndarray, weight: np.ndarray) -> None:
        """Set the frame's (J, 3) targets [m] and (J,) confidences; absent joints (weight 0) dropped."""
        self.active = np.flatnonzero(weight > 0)
        self.target, self.w = target[self.active], np.sqrt(weight[self.active])

    def weighted_rms(self, x: np.ndarray) -> float:
        """Confidence-weighted RMS distance of the active sites from their targets, metres."""
        self.pose(x)
        d2 = np.sum((self.d.site_xpos[self.sites[self.active]] - self.target) ** 2, axis=1)
        return float(np.sqrt(np.sum(self.w**2 * d2) / np.sum(self.w**2)))

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        self.pose(x)
        n = len(self.active)
        J = np.empty((3 * n + K + 3, K + 1))
        J[: 3 * n] = (self.site_jacobian(self.d, self.active) * self.w[:, None, None]).reshape(3 * n, K + 1)
        J[3 * n : 3 * n + K + 1] = np.diag(self.c)
        J[3 * n + K + 1 :] = self.twist
        return J

    def solve(self, x0: np.ndarray, max_nfev: int) -> Solution:
        """Fit the targets of :meth:`use` from ``x0``, which the smoothness term also pulls towards."""
        self.x_prev = x0
        return bounded_least_squares(self.residuals, self.jacobian, x0, self.lower, self.upper, max_nfev)


_RESTART_RATIO, _RESTART_MARGIN_M = 1.5, 0.01
"""A frame whose residual grew past both ratio x and margin + the previous frame's is fitted again
from :func:`sim.retarget_seed.restart_guess` (the warm start may sit in the wrong basin of a
gimbal-locked shoulder)."""


def retarget(humanoid: Humanoid, trajectory: LandmarkTrajectory, options: RetargetOptions = RetargetOptions(),
             *, progress: Callable[[int], None] | None = None) -> RetargetResult:
    """Fit the humanoid's coordinates to every frame of a landmark trajectory.

    Parameters
    ----------
    humanoid : Humanoid
        The subject, already scaled (e.g. with :func:`sim.retarget_scale.estimate_anthropometry`).
    trajectory : LandmarkTrajectory
        (T, J, 3) world-frame targets [m] with (T, J) confidences.
    options : RetargetOptions
    progress : callable, optional
        Called with the number of frames done since the last call.

    Returns
    -------
    RetargetResult
        Per-frame coordinates, residuals per frame and landmark, convergence flags.

    Raises
    ------
    BadInputError
        If no frame has a landmark to fit.
    """
    traj = bridge_gaps(trajectory, options.max_gap_s)
    topo = traj.topology
    problem = _Problem(humanoid, topo, options)
    T = traj.n_frames
    X = np.zeros((T, K + 1))
    rms = np.full(T, np.nan)
    ok = np.zeros(T, dtype=bool)
    nfev = np.zeros(T, dtype=int)
    has = (traj.confidence > 0).any(axis=1)
    if not has.any():
        raise BadInputError(f"{traj.source or 'the trajectory'} has no landmark in any frame: nothing to fit")
    first = int(np.argmax(has))
    x, last_fit = None, 0.0
    tick = progress or (lambda n: None)
    for t in range(T):
        target, weight = np.nan_to_num(traj.positions[t]), traj.confidence[t]
        if not has[t]:
            X[t] = X[t - 1] if t > 0 and x is not None else 0.0
            tick(1)
            continue
        start = x is None
        if start:
            x = initial_guess(target, weight, topo)
        problem.use(target, weight)
        bounds = problem.lower, problem.upper
        x = seed_arms(x, target, weight, topo, problem.parents(x), problem.weighted_rms, *bounds)
        sol = problem.solve(x, options.max_iterations * (10 if start else 1))
        fit = problem.weighted_rms(sol.x)
        if start or fit > max(_RESTART_RATIO * last_fit, last_fit + _RESTART_MARGIN_M):
            guess = restart_guess(sol.x, target, weight, topo, problem.parents(sol.x), problem.weighted_rms, *bounds)
            retry = problem.solve(guess, options.max_iterations * 2)
            retry_fit = problem.weighted_rms(retry.x)
            if retry_fit < fit:
                retry.nfev += sol.nfev
                sol, fit = retry, retry_fit
        x = sol.x
        if start and t > first:
            X[first:t] = x
        X[t] = x
        rms[t] = last_fit = fit
        ok[t] = sol.status >= 0 and fit <= options.max_rms_m
        nfev[t] = sol.nfev
        tick(1)
    if first > 0:
        X[:first] = X[first]
    coords = X[:, :K]
    coords[:, INDEX["root_yaw"]] = np.unwrap(coords[:, INDEX["root_yaw"]])
    site_pos = humanoid.joint_positions(coords, topo)
    # joint_positions grounds the feet; undo to compare with the fitted pelvis height
    pelvis = topo.index(Landmark.PELVIS)
    site_pos += (X[:, _Z] - site_pos[:, pelvis, 2])[:, None, None] * np.array([0.0, 0.0, 1.0])
    errors = np.linalg.norm(site_pos - trajectory.positions, axis=-1)
    return RetargetResult(traj.times, coords, X[:, _Z], errors, rms, ok, nfev, topo)
