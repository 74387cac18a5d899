"""Calibrating a rig of depth cameras from the person's own body.

Pipeline (observations only, never truth):

1. per camera, back-facing skeletons are detected (:mod:`fusion.backfacing`) and excluded; a
   stream without joint confidences gets them estimated from consistency
   (:mod:`fusion.calibrate.reliability`);
2. each camera's clock offset to the reference camera is estimated from the body motion, widening the
   search once (:mod:`fusion.calibrate.session_clocks`); a person who hardly moves is refused;
3. every pair of cameras with enough joints Tracked in both at the same time is calibrated by RANSAC
   over frames (:func:`fusion.calibrate.ransac.ransac_skeleton_pair`), bootstrap for the uncertainty;
4. optionally each pair is refined by ICP on body and floor points of several depth frames
   (:func:`fusion.calibrate.icp.refine_pair_icp`), kept only where it does not make things worse; with
   three or more cameras a rejected ICP is retried from the transform the other pairs imply, with two
   a rejected or far-moved ICP is cross-checked on other instants (:func:`fusion.calibrate.pair.cross_check_icp`);
5. the whole rig: edges that disagree with the cycles they close are down-weighted
   (:mod:`fusion.calibrate.consistency`), then chaining along the most certain paths to the
   reference camera (the paper), or a global pose-graph optimisation over all measured pairs
   (:mod:`fusion.calibrate.rig_graph`);
6. the world frame: floor fitted in the reference camera's depth (or through the feet), z up, floor
   at z = 0, origin under the subject's start position, x along the subject's initial facing.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from fusion.calibrate.consistency import EdgeCheck, down_weight
from fusion.calibrate.floor import FloorPlane, fit_floor_plane, world_from_floor
from fusion.calibrate.icp_points import select_calibration_points
from fusion.calibrate.loop import loop_closure
from fusion.calibrate.options import CalibrationOptions, Refinement, RigMethod
from fusion.calibrate.pair import (
    calibrate_pair,
    cross_check_icp,
    nearest_skeleton,
    retry_icp,
)
from fusion.calibrate.reliability import estimate_states, has_confidences
from fusion.calibrate.results import PairResult, RigCalibration
from fusion.calibrate.rig_graph import (
    GraphLoss,
    RigSolution,
    chain_to_reference,
    optimise_pose_graph,
)
from fusion.calibrate.session_clocks import session_clock_offsets, skeleton_cameras
from fusion.depth import Label, depth_to_points
from fusion.errors import BadInputError, CalibrationError, UnknownNameError
from fusion.facing import chest_normal, detect_back_facing
from fusion.recording import CameraRecording, Recording
from fusion.skeleton import SkeletonStream
from fusion.topology import Landmark, Region, TrackingState
from fusion.transforms import compose


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
            joints = nearest_skeleton(cam.skeleton, cam.depth.timestamps[k])
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
              refined: bool) -> tuple[dict[str, np.ndarray], RigSolution | None, tuple[EdgeCheck, ...]]:
    """Rig poses ``T_ref_cam`` from calibrated pairs by chaining or by the pose graph.

    Every pair is evidence with its uncertainty (:meth:`PairResult.edge`). With ``refined``, when
    the ICP-refined pairs alone connect every camera, only they are used: a skeleton-only pair
    carries the tracker's view-dependent bias, which would pull the graph away from the far more
    accurate refined pairs. Edges that disagree with the cycles they close are down-weighted first
    (:func:`fusion.calibrate.consistency.down_weight`), and the pose graph uses a robust loss.

    Returns
    -------
    T_ref_cam : camera -> (4, 4).
    solution : the pose-graph solution (None when chaining).
    checks : the cycle-consistency check of every edge used.
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
    edges, checks = down_weight(edges)
    chained = chain_to_reference(edges, reference, cameras=cameras)
    if method is RigMethod.CHAIN:
        return chained, None, checks
    solution = optimise_pose_graph(edges, reference, initial=chained, loss=GraphLoss.HUBER)
    return dict(solution.T_ref_cam), solution, checks


def _retry_rejected(pairs: list[PairResult], by_name: dict[str, CameraRecording], options: CalibrationOptions,
                    rng: np.random.Generator, tell: Callable[[str], None]) -> list[PairResult]:
    """Pairs whose ICP was rejected, refined again from the transform the other pairs imply."""
    out = list(pairs)
    for i, pair in enumerate(pairs):
        if pair.icp is None or pair.icp.accepted:
            continue
        others = {(q.a, q.b): q.edge(refined=True) for q in out if q is not out[i]}
        others, _ = down_weight(others)
        try:
            T_a_b = chain_to_reference(others, pair.a)[pair.b]
        except (CalibrationError, UnknownNameError, KeyError):
            continue
        out[i] = retry_icp(by_name[pair.a], by_name[pair.b], pair, T_a_b, options, rng=rng)
        tell(f"pair {pair.a}-{pair.b}: ICP retried ({'accepted' if out[i].refined else 'rejected'})")
    return out


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
    cams = skeleton_cameras(recording)
    offsets, notes = session_clock_offsets(recording, options)
    if options.estimate_confidence:
        estimated = [c.name for c in cams if not has_confidences(c.skeleton)]
        cams = [replace(c, skeleton=estimate_states(c.skeleton)) if c.name in estimated else c for c in cams]
        if estimated:
            notes.append(f"cameras {', '.join(estimated)} carry no joint confidences: estimated from the joints' "
                         "temporal and bone-length consistency")
    by_name = {c.name: c for c in cams}
    reference = options.reference or cams[0].name
    back = {c.name: detect_back_facing(c.skeleton).flipped for c in cams}
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
        if missing := [Region(r).name for r, n in enumerate(pair.ransac.region_counts) if n == 0]:
            notes.append(f"pair {a}-{b}: no {', '.join(missing)} joint tracked in both cameras; calibrated from the "
                         "other body regions (record the whole body in view of both cameras for a better fit)")
        pairs.append(pair)
        tell(f"pair {a}-{b}: support {pair.ransac.support:.0%}")
    if not pairs:
        raise CalibrationError("no camera pair could be calibrated:\n  " + "\n  ".join(notes))
    if options.refine is Refinement.ICP and len(by_name) >= 3:
        retried = _retry_rejected(pairs, by_name, options, rng, tell)
        notes += [f"pair {q.a}-{q.b}: {q.icp_note}" for p, q in zip(pairs, retried, strict=True) if q is not p]
        pairs = retried
    elif options.refine is Refinement.ICP:
        checked = [cross_check_icp(by_name[p.a], by_name[p.b], p, options, rng=rng) for p in pairs]
        notes += [f"pair {q.a}-{q.b}: {q.icp_note}" for p, q in zip(pairs, checked, strict=True) if q is not p]
        pairs = checked
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
    T_ref_cam, solution, checks = solve_rig(pairs, list(measurements.cameras), reference, rig, refined=refined)
    notes += [f"edge {c.key[0]}-{c.key[1]} distrusted: disagrees with the path {'-'.join(c.path)} by "
              f"{c.rotation_deg:.2f} deg / {c.translation_mm:.1f} mm ({c.z:.1f} sigma), weight {c.weight:.3f}"
              for c in checks if c.distrusted]
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
        edge_checks=checks,
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
