"""Calibrating a rig of depth cameras from the person's own body.

Pipeline (observations only, never truth):

1. per camera, back-facing skeletons are detected (:mod:`fusion.backfacing`) and excluded;
2. each camera's residual clock offset to the reference camera is estimated from the body motion
   (:func:`fusion.sync.estimate_clock_offset`) and corrected when frames are associated;
3. every pair of cameras with enough joints Tracked in both at the same time is calibrated by
   RANSAC over frames (:func:`fusion.ransac.ransac_skeleton_pair`), with a bootstrap of the
   inliers for the uncertainty;
4. optionally each pair is refined by ICP on body and floor points of several depth frames
   (:func:`fusion.icp.refine_pair_icp`), kept only where it does not make things worse;
5. the whole rig: chaining along shortest paths to the reference camera (the paper), or a global
   pose-graph optimisation over all measured pairs (:mod:`fusion.rig_graph`);
6. the world frame: floor fitted in the reference camera's depth (or through the feet), z up, floor
   at z = 0, origin under the subject's start position, x along the subject's initial facing.
"""

from __future__ import annotations

import enum
import itertools
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from fusion.backfacing import chest_normal, detect_back_facing
from fusion.camera import Intrinsics
from fusion.depth import Label, depth_to_points
from fusion.errors import BadInputError, CalibrationError, UnknownNameError
from fusion.floor import FloorPlane, fit_floor_plane, world_from_floor
from fusion.icp import IcpMethod, IcpResult, refine_pair_icp, select_calibration_points
from fusion.kabsch import kabsch_batch
from fusion.ransac import PairCalibration, ransac_skeleton_pair
from fusion.recording import CameraRecording, Recording
from fusion.rig_graph import LoopClosure, PairEdge, RigSolution, chain_to_reference, loop_closure, optimise_pose_graph
from fusion.skeleton import SkeletonStream
from fusion.sync import ClockOffset, associate, estimate_clock_offset
from fusion.topology import Landmark, TrackingState
from fusion.transforms import compose, invert, transform_difference


class Refinement(enum.Enum):
    """Refinement of the skeleton-based pair transforms."""

    NONE = "none"
    ICP = "icp"


class RigMethod(enum.Enum):
    """How pairwise transforms become one consistent rig."""

    CHAIN = "chain"
    """The paper's chaining along the shortest path to the reference camera."""
    GRAPH = "graph"
    """Global least-squares pose graph over all measured pairs."""


@dataclass(frozen=True)
class CalibrationOptions:
    """Settings of :func:`calibrate_rig` (defaults suit Kinect v2 class sensors at 1.5-3 m).

    Attributes
    ----------
    refine, rig : see :class:`Refinement` and :class:`RigMethod`.
    reference : name of the reference camera; default the first camera.
    n_trials : RANSAC hypotheses per pair.
    inlier_threshold_m : RANSAC inlier distance [m].
    tolerance_s : frames of two cameras closer than this in time [s] are simultaneous.
    estimate_clock : estimate residual clock offsets from the motion (else trust the timestamps).
    max_clock_offset_s : largest clock offset searched [s].
    min_candidates : shared Tracked joint measurements a pair needs to be calibrated at all.
    bootstrap : bootstrap resamples of the inliers for the uncertainty.
    icp_instants : depth frame pairs used by ICP, spread over the session (varied poses and
        orientations constrain ICP best).
    icp_max_speed_mps : only depth frame pairs where the body's median joint speed is below this
        [m/s] are used, so the two cameras' frames, captured milliseconds apart, show the same body.
    icp_max_angle_deg : ICP only for pairs whose viewing directions differ by at most this [deg]:
        cameras further apart see different sides of the body, and ICP would slide one onto the other.
    icp_rotation_std_deg, icp_translation_std_mm : uncertainty given to an ICP-refined pair in the
        pose graph (its systematic accuracy in simulation).
    skeleton_rotation_std_deg, skeleton_translation_std_mm : systematic uncertainty of a skeleton-only
        pair (the tracker's view-dependent bias), added in quadrature to its bootstrap spread, which
        measures only the random part.
    min_motion_m : a pair needs the person to move at least this much [m] (see :func:`motion_extent_m`)
        while both cameras see them; a static body gives too little geometry.
    depth_tolerance_s : depth frames of two cameras closer than this [s] form an ICP instant.
    icp_method : ICP error metric.
    """

    refine: Refinement = Refinement.ICP
    rig: RigMethod = RigMethod.GRAPH
    reference: str | None = None
    n_trials: int = 2000
    inlier_threshold_m: float = 0.08
    tolerance_s: float = 1.0 / 60.0
    estimate_clock: bool = True
    max_clock_offset_s: float = 0.2
    min_candidates: int = 200
    bootstrap: int = 50
    icp_instants: int = 6
    depth_tolerance_s: float = 0.03
    icp_method: IcpMethod = IcpMethod.POINT_TO_PLANE
    icp_max_speed_mps: float = 0.3
    icp_max_angle_deg: float = 100.0
    icp_rotation_std_deg: float = 0.2
    icp_translation_std_mm: float = 3.0
    skeleton_rotation_std_deg: float = 1.0
    skeleton_translation_std_mm: float = 30.0
    min_motion_m: float = 0.10

    def __post_init__(self) -> None:
        if not isinstance(self.refine, Refinement) or not isinstance(self.rig, RigMethod):
            raise BadInputError("refine must be a Refinement and rig a RigMethod")
        positive = {k: getattr(self, k) for k in ("n_trials", "inlier_threshold_m", "tolerance_s",
                                                  "max_clock_offset_s", "min_candidates", "bootstrap",
                                                  "icp_instants", "depth_tolerance_s", "icp_max_speed_mps",
                                                  "icp_max_angle_deg", "icp_rotation_std_deg",
                                                  "icp_translation_std_mm", "skeleton_rotation_std_deg",
                                                  "skeleton_translation_std_mm", "min_motion_m")}
        bad = {k: v for k, v in positive.items() if not (np.isfinite(v) and v > 0)}
        if bad:
            raise BadInputError(f"calibration options must be positive: {bad}")


@dataclass(frozen=True, eq=False)
class PairResult:
    """Calibration of camera ``b`` against camera ``a``.

    Attributes
    ----------
    a, b : camera names.
    T_a_b_skeleton : (4, 4) transform from the skeleton RANSAC.
    T_a_b : (4, 4) final transform (the ICP result where it was accepted).
    ransac : RANSAC diagnostics (inliers, support, residuals per joint, trials).
    icp : ICP diagnostics, or None when not run.
    clock_offset_s : clock of b minus clock of a [s] used to associate frames.
    n_frame_pairs : simultaneous frame pairs.
    rotation_std_deg, translation_std_mm : bootstrap standard deviation of the skeleton transform.
    icp_note : why ICP was not run or not used (None when it refined the pair or was not asked for).
    icp_std, skeleton_std : (rotation [deg], translation [mm]) systematic uncertainty of an ICP-refined
        and of a skeleton transform.
    """

    a: str
    b: str
    T_a_b_skeleton: np.ndarray
    T_a_b: np.ndarray
    ransac: PairCalibration
    icp: IcpResult | None
    clock_offset_s: float
    n_frame_pairs: int
    rotation_std_deg: float
    translation_std_mm: float
    icp_note: str | None = None
    icp_std: tuple[float, float] = (0.2, 3.0)
    skeleton_std: tuple[float, float] = (1.0, 30.0)

    @property
    def refined(self) -> bool:
        """True when ICP refined this pair."""
        return self.icp is not None and self.icp.accepted

    def edge(self, *, refined: bool = True) -> PairEdge:
        """The pose-graph edge of this pair: the final (or the skeleton) transform with its uncertainty."""
        if refined and self.refined:
            return PairEdge.from_std(self.T_a_b, self.icp_std[0], self.icp_std[1] * 1e-3)
        return PairEdge.from_std(self.T_a_b_skeleton, float(np.hypot(self.rotation_std_deg, self.skeleton_std[0])),
                                 float(np.hypot(self.translation_std_mm, self.skeleton_std[1])) * 1e-3)


@dataclass(frozen=True, eq=False)
class RigCalibration:
    """A calibrated rig with every diagnostic.

    Attributes
    ----------
    reference : the reference camera.
    T_world_cam : camera name -> (4, 4) pose in the world frame (z up, floor z = 0).
    T_ref_cam : camera name -> (4, 4) pose in the reference camera's frame.
    intrinsics : camera name -> intrinsics (copied from the recording).
    clock_offset_s : camera name -> its clock minus the reference's [s].
    pairs : every calibrated pair.
    refine, rig : the methods used.
    solution : the pose-graph solution (None when chaining).
    floor : the floor in the reference frame (None if no floor was found).
    loop : the paper's ring loop closure of the pairwise transforms (None unless >= 3 cameras in a ring).
    notes : what was skipped or fell back, and why.
    """

    reference: str
    T_world_cam: dict[str, np.ndarray]
    T_ref_cam: dict[str, np.ndarray]
    intrinsics: dict[str, Intrinsics]
    clock_offset_s: dict[str, float]
    pairs: tuple[PairResult, ...]
    refine: Refinement
    rig: RigMethod
    solution: RigSolution | None = None
    floor: FloorPlane | None = None
    loop: LoopClosure | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def camera_names(self) -> tuple[str, ...]:
        """Calibrated cameras."""
        return tuple(self.T_world_cam)


def _skeleton_cameras(recording: Recording) -> list[CameraRecording]:
    cams = [c for c in recording.cameras if c.skeleton is not None and c.skeleton.n_frames > 0]
    if len(cams) < 2:
        raise CalibrationError(
            f"calibration needs at least two cameras with skeleton streams; this recording has "
            f"{len(cams)} ({', '.join(c.name for c in cams) or 'none'}). Record with two or more cameras."
        )
    for c in cams:
        if not np.any(c.skeleton.states >= TrackingState.TRACKED):
            raise CalibrationError(
                f"camera {c.name} never tracks the person (no Tracked joint in {c.skeleton.n_frames} frames): "
                "check that the person is inside its field of view and range, then record again"
            )
    return cams


def motion_extent_m(stream: SkeletonStream, *, min_frames: int = 30) -> float:
    """How far the person moves [m]: the largest, over joints, 80th-percentile distance of a Tracked
    joint from its median position (robust to outlier bursts; 0 without enough frames)."""
    P = np.where((stream.states >= TrackingState.TRACKED)[..., None], stream.positions, np.nan)
    seen = np.isfinite(P[..., 0]).sum(axis=0) >= min_frames
    if not seen.any():
        return 0.0
    P = P[:, seen]
    dist = np.linalg.norm(P - np.nanmedian(P, axis=0), axis=-1)
    return float(np.nanmax(np.nanpercentile(dist, 80, axis=0)))


def _bootstrap_std(result: PairCalibration, stream_a: SkeletonStream, stream_b: SkeletonStream, n: int,
                   rng: np.random.Generator) -> tuple[float, float]:
    """Standard deviation of the rotation [deg] and translation [mm] over bootstrap refits of the inliers
    (resampled with replacement, each keeping its weight in the final fit)."""
    used = result.fit_weights > 0
    cand = result.candidates[used]
    p_a = stream_a.positions[cand[:, 0], cand[:, 2]]
    p_b = stream_b.positions[cand[:, 1], cand[:, 2]]
    counts = rng.multinomial(cand.shape[0], np.full(cand.shape[0], 1.0 / cand.shape[0]), size=n)
    weights = counts * result.fit_weights[used]
    T, ok = kabsch_batch(np.broadcast_to(p_b, (n,) + p_b.shape), np.broadcast_to(p_a, (n,) + p_a.shape), weights)
    angle, dist = transform_difference(T[ok], result.T_a_b)
    return float(np.sqrt(np.mean(angle**2))), float(np.sqrt(np.mean(dist**2)) * 1e3)


def _nearest_skeleton(stream: SkeletonStream, t: float) -> np.ndarray:
    """(J, 3) joints of the skeleton frame nearest to camera time ``t``."""
    return stream.positions[int(np.argmin(np.abs(stream.timestamps - t)))]


def body_speed(stream: SkeletonStream, times: np.ndarray, *, half_window_s: float = 0.1) -> np.ndarray:
    """(N,) median speed [m/s] of the Tracked joints around each camera time; NaN where unknown.

    Used to pick the instants when the person is most still, so that two cameras' depth frames
    captured a few milliseconds apart show the same body.
    """
    ts, P = stream.timestamps, np.where((stream.states >= TrackingState.TRACKED)[..., None], stream.positions, np.nan)
    lo = np.clip(np.searchsorted(ts, times - half_window_s), 0, ts.size - 1)
    hi = np.clip(np.searchsorted(ts, times + half_window_s), 0, ts.size - 1)
    dt = ts[hi] - ts[lo]
    with np.errstate(invalid="ignore", divide="ignore"):
        v = np.linalg.norm(P[hi] - P[lo], axis=-1) / dt[:, None]
    v[dt <= 0] = np.nan
    out = np.full(times.shape, np.nan)
    have = np.isfinite(v).any(axis=1)
    out[have] = np.nanmedian(v[have], axis=1)
    return out


def _icp_pair(cam_a: CameraRecording, cam_b: CameraRecording, T_a_b: np.ndarray, offset_s: float,
              options: CalibrationOptions, rng: np.random.Generator) -> tuple[IcpResult | None, str | None]:
    """ICP of one pair on its simultaneous depth frames, or (None, why not)."""
    if cam_a.depth is None or cam_b.depth is None:
        return None, "no depth frames in one of the cameras"
    pairs = associate(cam_a.depth.timestamps, cam_b.depth.timestamps, tolerance_s=options.depth_tolerance_s,
                      offset_s=offset_s)
    if pairs.n_pairs == 0:
        return None, "no simultaneous depth frames"
    speed = body_speed(cam_a.skeleton, cam_a.depth.timestamps[pairs.index_a])
    calm = np.flatnonzero(np.isfinite(speed) & (speed <= options.icp_max_speed_mps))
    if calm.size == 0:
        return None, f"the person never moves slower than {options.icp_max_speed_mps} m/s in a depth frame pair"
    chosen = pairs.indices[calm[np.unique(np.linspace(0, calm.size - 1, options.icp_instants).round().astype(int))]]
    clouds_a, clouds_b = [], []
    for ia, ib in chosen:
        pa = select_calibration_points(cam_a.depth.depth_mm[ia], None if cam_a.depth.labels is None else
                                       cam_a.depth.labels[ia], cam_a.intrinsics, rng=rng,
                                       joints_cam=_nearest_skeleton(cam_a.skeleton, cam_a.depth.timestamps[ia]))
        pb = select_calibration_points(cam_b.depth.depth_mm[ib], None if cam_b.depth.labels is None else
                                       cam_b.depth.labels[ib], cam_b.intrinsics, rng=rng,
                                       joints_cam=_nearest_skeleton(cam_b.skeleton, cam_b.depth.timestamps[ib]))
        if pa.shape[0] >= 50 and pb.shape[0] >= 50:
            clouds_a.append(pa)
            clouds_b.append(pb)
    if not clouds_a:
        return None, "no depth frame pair shows the person in both cameras"
    return refine_pair_icp(clouds_a, clouds_b, T_a_b, method=options.icp_method), None


def calibrate_pair(
    cam_a: CameraRecording,
    cam_b: CameraRecording,
    options: CalibrationOptions,
    *,
    rng: np.random.Generator,
    clock_offset_s: float = 0.0,
    back_facing: tuple[np.ndarray, np.ndarray] | None = None,
) -> PairResult:
    """Calibrate camera b against camera a from the person's body (and depth, if asked).

    Parameters
    ----------
    cam_a, cam_b : the two cameras' recordings (skeleton streams required).
    options : calibration settings.
    rng : source of the RANSAC hypotheses, bootstrap and floor fits.
    clock_offset_s : clock of b minus clock of a [s].
    back_facing : (T_a,) and (T_b,) bool masks of back-facing skeletons to exclude; detected if None.

    Raises
    ------
    CalibrationError
        Too few simultaneous frames or shared Tracked joints, a static person, or only back views.
    """
    sa, sb = cam_a.skeleton, cam_b.skeleton
    if sa is None or sb is None:
        raise CalibrationError(f"pair {cam_a.name}-{cam_b.name}: both cameras need skeleton streams")
    if back_facing is None:
        back_facing = (detect_back_facing(sa).flipped, detect_back_facing(sb).flipped)
    pairs = associate(sa.timestamps, sb.timestamps, tolerance_s=options.tolerance_s, offset_s=clock_offset_s)
    if pairs.n_pairs == 0:
        raise CalibrationError(
            f"pair {cam_a.name}-{cam_b.name}: no simultaneous frames (within {options.tolerance_s * 1e3:.0f} ms); "
            "the recordings do not overlap in time or their clocks differ by more than the searched offset"
        )
    ia, ib = pairs.index_a, pairs.index_b
    front = ~back_facing[0][ia] & ~back_facing[1][ib]
    shared = (sa.states[ia] >= TrackingState.TRACKED) & (sb.states[ib] >= TrackingState.TRACKED)
    n_shared = int(shared[front].sum())
    if n_shared < options.min_candidates:
        all_back = int(shared.sum()) >= options.min_candidates
        raise CalibrationError(
            f"pair {cam_a.name}-{cam_b.name}: only {n_shared} joint measurements are Tracked in both cameras "
            f"at the same time with the person facing them (need {options.min_candidates})"
            + ("; most shared views are from behind: record the person facing between the cameras"
               if all_back else "; record a session in which the person is seen well by both cameras at once")
        )
    extent = motion_extent_m(sa.subset(ia[front]))
    if extent < options.min_motion_m:
        raise CalibrationError(
            f"pair {cam_a.name}-{cam_b.name}: the person hardly moves while both cameras see them (no joint moves "
            f"more than {extent * 100:.0f} cm, need {options.min_motion_m * 100:.0f} cm), so the body's poses cannot "
            "pin down the cameras' relative pose; record the person turning in place and raising the arms"
        )
    result = ransac_skeleton_pair(sa, sb, pairs, rng=rng, n_trials=options.n_trials,
                                  inlier_threshold_m=options.inlier_threshold_m,
                                  exclude_frames_a=back_facing[0], exclude_frames_b=back_facing[1])
    rot_std, trans_std = _bootstrap_std(result, sa, sb, options.bootstrap, rng)
    icp, icp_note = None, None
    T_final = result.T_a_b
    if options.refine is Refinement.ICP:
        axes_deg = np.degrees(np.arccos(np.clip(result.T_a_b[2, 2], -1.0, 1.0)))
        if axes_deg > options.icp_max_angle_deg:
            icp_note = (f"viewing directions {axes_deg:.0f} deg apart (ICP limit {options.icp_max_angle_deg:.0f} deg); "
                        "skeleton transform kept")
        else:
            icp, why_not = _icp_pair(cam_a, cam_b, result.T_a_b, clock_offset_s, options, rng)
            if icp is None:
                icp_note = f"ICP not run: {why_not}"
            elif icp.accepted:
                T_final = icp.T_a_b
            else:
                icp_note = f"ICP result not used ({icp.reason}); skeleton transform kept"
    return PairResult(cam_a.name, cam_b.name, result.T_a_b, T_final, result, icp, clock_offset_s,
                      pairs.n_pairs, rot_std, trans_std, icp_note,
                      (options.icp_rotation_std_deg, options.icp_translation_std_mm),
                      (options.skeleton_rotation_std_deg, options.skeleton_translation_std_mm))


def _clock_offsets(ref: CameraRecording, cams: list[CameraRecording], options: CalibrationOptions,
                   notes: list[str]) -> dict[str, float]:
    offsets = {ref.name: 0.0}
    for cam in cams:
        if cam.name == ref.name:
            continue
        offsets[cam.name] = 0.0
        if not options.estimate_clock:
            continue
        try:
            est: ClockOffset = estimate_clock_offset(ref.skeleton, cam.skeleton, max_offset_s=options.max_clock_offset_s)
        except CalibrationError as exc:
            notes.append(f"clock offset {cam.name}: not estimated ({exc}); timestamps trusted")
            continue
        if est.converged:
            offsets[cam.name] = est.offset_s
        else:
            notes.append(f"clock offset {cam.name}: estimate did not converge (peak score {est.peak_score:.2f}); "
                         "timestamps trusted")
    return offsets


def _floor_points(cam: CameraRecording, rng: np.random.Generator) -> np.ndarray | None:
    """Floor candidates of one camera: FLOOR-labelled depth points, or depth points near the feet."""
    if cam.depth is None or cam.depth.n_frames == 0:
        return None
    picks = np.unique(np.linspace(0, cam.depth.n_frames - 1, 3).round().astype(int))
    chunks = []
    for k in picks:
        if cam.depth.labels is not None:
            pts, lab = depth_to_points(cam.depth.depth_mm[k], cam.intrinsics, cam.depth.labels[k])
            chunks.append(pts[lab == Label.FLOOR])
        else:
            joints = _nearest_skeleton(cam.skeleton, cam.depth.timestamps[k])
            pts = select_calibration_points(cam.depth.depth_mm[k], None, cam.intrinsics, rng=rng, joints_cam=joints)
            chunks.append(pts)
    pts = np.concatenate(chunks)
    if pts.shape[0] > 20000:
        pts = pts[rng.choice(pts.shape[0], 20000, replace=False)]
    return pts if pts.shape[0] >= 100 else None


def _start_pose(stream: SkeletonStream, back: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """Pelvis position (3,) and facing direction (3,) or None at the start, in the camera frame."""
    topo, P = stream.topology, stream.positions
    pelvis = P[:, topo.index(Landmark.PELVIS)]
    have = np.flatnonzero(np.isfinite(pelvis).all(axis=1))
    if have.size == 0:
        raise CalibrationError("the reference camera never sees the pelvis; choose another reference camera")
    first = have[stream.timestamps[have] <= stream.timestamps[have[0]] + 1.0]
    start = np.median(pelvis[first], axis=0)
    normal = chest_normal(P[first], topo) * np.where(back[first], -1.0, 1.0)[:, None]
    normal = normal[np.isfinite(normal).all(axis=1)]
    return start, (np.median(normal, axis=0) if normal.shape[0] else None)


def _world_frame(ref: CameraRecording, back: np.ndarray, rng: np.random.Generator,
                 notes: list[str]) -> tuple[np.ndarray, FloorPlane | None]:
    start, facing = _start_pose(ref.skeleton, back)
    pts = _floor_points(ref, rng)
    if pts is None:
        topo, P = ref.skeleton.topology, ref.skeleton.positions
        feet = P[:, topo.indices([Landmark.FOOT_LEFT, Landmark.FOOT_RIGHT, Landmark.ANKLE_LEFT,
                                  Landmark.ANKLE_RIGHT])].reshape(-1, 3)
        pts = feet[np.isfinite(feet).all(axis=1)]
        notes.append("world frame: no depth floor in the reference camera; floor fitted through the feet")
    floor = fit_floor_plane(pts, rng=rng, threshold_m=0.02 if pts.shape[0] < 5000 else 0.01)
    return world_from_floor(floor, start, facing), floor


def _ring_order(T_world_cam: dict[str, np.ndarray], centre: np.ndarray) -> list[str]:
    """Cameras sorted clockwise (seen from above) around ``centre`` (world xy)."""
    angles = {n: np.arctan2(T[1, 3] - centre[1], T[0, 3] - centre[0]) for n, T in T_world_cam.items()}
    return sorted(angles, key=lambda n: -angles[n])


def _loop_points(cam: CameraRecording) -> np.ndarray:
    """Body points of one camera for the ring loop-closure measure: its Tracked joints over time."""
    sk = cam.skeleton
    pts = sk.positions[sk.states >= TrackingState.TRACKED]
    return pts[:: max(1, pts.shape[0] // 2000)]


def solve_rig(pairs: list[PairResult], cameras: list[str], reference: str, method: RigMethod, *,
              refined: bool) -> tuple[dict[str, np.ndarray], RigSolution | None]:
    """Rig poses ``T_ref_cam`` from calibrated pairs by chaining or by the pose graph.

    With ``refined``, when the ICP-refined pairs alone connect every camera, only they are used:
    a skeleton-only pair carries the tracker's view-dependent bias, which would pull the graph away
    from the far more accurate refined pairs. Otherwise every pair takes part, weighted by its
    uncertainty.
    """
    edges = {(p.a, p.b): p.edge(refined=refined) for p in pairs}
    if refined:
        icp_edges = {(p.a, p.b): p.edge(refined=True) for p in pairs if p.refined}
        try:
            chain_to_reference(icp_edges, reference, cameras=cameras)
            edges = icp_edges
        except (CalibrationError, UnknownNameError):
            pass
    if not edges:
        raise CalibrationError("no camera pair could be calibrated; see the notes for each pair")
    if method is RigMethod.CHAIN:
        return chain_to_reference(edges, reference, cameras=cameras), None
    chained = chain_to_reference(edges, reference, cameras=cameras)
    solution = optimise_pose_graph(edges, reference, initial=chained)
    return dict(solution.T_ref_cam), solution


@dataclass(frozen=True, eq=False)
class PairMeasurements:
    """Every pairwise calibration of a recording, before the rig is assembled.

    Attributes
    ----------
    reference : reference camera.
    cameras : cameras with skeleton streams, in recording order.
    pairs : calibrated pairs (skeleton and, where run, ICP transforms).
    clock_offset_s : camera -> its clock minus the reference's [s].
    back_facing : camera -> (T,) bool back-facing skeletons detected.
    notes : skipped pairs and fallbacks, with reasons.
    refine : whether ICP was asked for.
    """

    reference: str
    cameras: tuple[str, ...]
    pairs: tuple[PairResult, ...]
    clock_offset_s: dict[str, float]
    back_facing: dict[str, np.ndarray]
    notes: tuple[str, ...]
    refine: Refinement


def measure_pairs(
    recording: Recording,
    options: CalibrationOptions = CalibrationOptions(),
    *,
    rng: np.random.Generator,
    progress: Callable[[str], None] | None = None,
) -> PairMeasurements:
    """Steps 1-4 of the pipeline: back-facing detection, clock offsets, every calibratable pair.

    Pairs that cannot be calibrated are skipped with a note; see :func:`calibrate_pair`.
    """
    tell = progress or (lambda msg: None)
    cams = _skeleton_cameras(recording)
    by_name = {c.name: c for c in cams}
    reference = options.reference or cams[0].name
    if reference not in by_name:
        raise UnknownNameError("reference camera", reference, by_name)
    notes: list[str] = []
    back = {c.name: detect_back_facing(c.skeleton).flipped for c in cams}
    offsets = _clock_offsets(by_name[reference], cams, options, notes)
    tell("clock offsets estimated")
    pairs: list[PairResult] = []
    for a, b in itertools.combinations([c.name for c in cams], 2):
        try:
            pair = calibrate_pair(by_name[a], by_name[b], options, rng=rng, clock_offset_s=offsets[b] - offsets[a],
                                  back_facing=(back[a], back[b]))
        except CalibrationError as exc:
            notes.append(str(exc))
            tell(f"pair {a}-{b}: skipped")
            continue
        if pair.icp_note:
            notes.append(f"pair {a}-{b}: {pair.icp_note}")
        pairs.append(pair)
        tell(f"pair {a}-{b}: support {pair.ransac.support:.0%}")
    if not pairs:
        raise CalibrationError("no camera pair could be calibrated:\n  " + "\n  ".join(notes))
    return PairMeasurements(reference, tuple(by_name), tuple(pairs), offsets, back, tuple(notes), options.refine)


def assemble_rig(
    recording: Recording,
    measurements: PairMeasurements,
    *,
    rig: RigMethod,
    refined: bool,
    rng: np.random.Generator,
) -> RigCalibration:
    """Steps 5-6: one consistent rig in the world frame from measured pairs.

    Parameters
    ----------
    recording : the recording the pairs were measured on (for the floor and the ring points).
    measurements : from :func:`measure_pairs`.
    rig : chaining or pose graph.
    refined : use the ICP-refined transforms where ICP was accepted (else the skeleton ones).
    rng : random source of the floor fit.
    """
    by_name = {n: recording.camera(n) for n in measurements.cameras}
    reference = measurements.reference
    notes = list(measurements.notes)
    pairs = list(measurements.pairs)
    T_ref_cam, solution = solve_rig(pairs, list(measurements.cameras), reference, rig, refined=refined)
    T_world_ref, floor = _world_frame(by_name[reference], measurements.back_facing[reference], rng, notes)
    T_world_cam = {n: compose(T_world_ref, T_ref_cam[n]) for n in T_ref_cam}
    loop = None
    if len(T_world_cam) >= 3:
        order = _ring_order(T_world_cam, np.zeros(2))
        edges = {(p.a, p.b): p.edge(refined=refined) for p in pairs}
        try:
            loop = loop_closure(edges, order, {n: _loop_points(by_name[n]) for n in order})
        except BadInputError as exc:
            notes.append(f"loop closure not measured: {exc}")
    return RigCalibration(
        reference=reference,
        T_world_cam=T_world_cam,
        T_ref_cam=T_ref_cam,
        intrinsics={n: by_name[n].intrinsics for n in T_world_cam},
        clock_offset_s={n: measurements.clock_offset_s[n] for n in T_world_cam},
        pairs=tuple(pairs),
        refine=Refinement.ICP if refined and measurements.refine is Refinement.ICP else Refinement.NONE,
        rig=rig,
        solution=solution,
        floor=floor,
        loop=loop,
        notes=tuple(notes),
    )


def calibrate_rig(
    recording: Recording,
    options: CalibrationOptions = CalibrationOptions(),
    *,
    rng: np.random.Generator,
    progress: Callable[[str], None] | None = None,
) -> RigCalibration:
    """Calibrate every camera of ``recording`` from the person's body (the whole pipeline).

    Parameters
    ----------
    recording : two or more cameras with skeleton streams (depth optional; needed for ICP).
    options : methods and thresholds.
    rng : the one random source (RANSAC, bootstrap, floor fit).
    progress : called with a short message after each step.

    Returns
    -------
    RigCalibration
        ``T_world_cam`` for every camera connected to the reference, with diagnostics and notes.

    Raises
    ------
    CalibrationError
        Fewer than two usable cameras, no calibratable pair, or cameras no pair connects (named).
    """
    measurements = measure_pairs(recording, options, rng=rng, progress=progress)
    result = assemble_rig(recording, measurements, rig=options.rig, refined=options.refine is Refinement.ICP, rng=rng)
    if progress:
        progress("rig solved")
    return result


def relative_poses(T_world_cam: dict[str, np.ndarray], reference: str) -> dict[str, np.ndarray]:
    """``T_ref_cam`` of every camera from world poses."""
    T_ref_world = invert(T_world_cam[reference])
    return {n: compose(T_ref_world, T) for n, T in T_world_cam.items()}

