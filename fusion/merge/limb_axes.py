"""Limb axes from the depth clouds: where the upper arms, forearms, thighs and shanks really lie.

Every camera's tracker places the joints where the same body model puts them (the body-model bias),
so no fusion of joints removes that. The depth frames see the limbs' surfaces instead: per depth
instant each limb segment's points are fitted with a cylinder and its end joints moved onto the axis.

- **Points.** Every calibrated camera's body points of its depth frame nearest the instant
  (:func:`fusion.merge.cloud.frames_at`), in the world frame (of a frame without segmentation
  labels, the points above the floor near the skeleton). Each point goes to the nearest bone
  of the skeleton estimate (the cameras' weighted mean joints, :func:`~fusion.merge.kinematic.measurement_targets`);
  a limb segment keeps its points within its radius plus ``reach_m`` and between ``span`` of its
  length (away from the joints, where the neighbouring segments' surfaces meet it), at most
  ``max_points`` of them, evenly strided.
- **Radius.** One per segment and session: free-radius fits at the ``radius_instants`` instants at
  which the segment or its mirror image is farthest from the rest of the body (:func:`isolation`:
  an arm hanging beside the trunk shares its surface with the trunk's), the median radius of the
  better half (by residual) of those that pass the checks below, both sides pooled. A limb seen from
  one side constrains its radius poorly; a fixed radius makes the axis fit well posed.
- **Axis.** Robust Gauss-Newton on the distance of each point from the cylinder's surface (Huber
  weights of scale ``huber_m``), four degrees of freedom (the line), then refitted twice on the
  points within ``trim_m`` of the surface.
- **Checks.** A fit counts when it keeps at least ``min_points`` points and ``min_inlier_share`` of
  its points, its RMS residual is at most ``max_rms_m`` and its axis turns at most ``max_turn_deg``
  from the skeleton's segment.
- **Corrections** (:mod:`fusion.merge.limb_corrections`). Each joint of a counted segment goes to
  the least-squares point of the counted axes through it, pulled toward its measured position with
  weight ``pull``: across one axis (a segment's cloud does not say where along the axis its joint
  lies), to where two axes at an angle pass closest (a bent elbow or knee). The corrections are
  interpolated in time onto the skeleton frames (zero farther than ``max_gap_s`` from a counted
  instant) and added to every camera's measurement.
- **Pivots** (:mod:`fusion.merge.pivots`). Where an upper arm's or thigh's axes point in directions
  different enough (``pivot_min_spread``), the point they meet in the trunk's frame is the joint's
  functional centre, and the joint is pulled toward it with weight ``anchor_pull``: that places the
  shoulder along its humerus and the hip along its thigh (and the pelvis between two such hips).
- **Hands** (:mod:`fusion.merge.hand_ends`). Beyond each corrected wrist, the far end of the body's
  points is the hand tip, and the hand joint lies between the wrist and it; both are pulled there
  with weight ``anchor_pull``.

What it cannot correct: where along a limb a joint lies without a pivot (the hip of a person whose
thighs keep one direction in the trunk; the elbow, wrist, knee and ankle along a straight limb), the
spine above the pelvis, the thumbs and the feet. The simulated limbs are capsules about their bones,
so in simulation a cylinder's axis is the bone exactly; a real limb's soft tissue is not centred on
its bone (the thigh's axis and the femur's mechanical axis differ by a few degrees), which bounds
what the correction can do on real recordings.
"""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np

from fusion.arrays import segment_distances, unit
from fusion.calibrate.sync import nearest_index
from fusion.calibration import Calibration
from fusion.errors import BadInputError
from fusion.merge.cloud import frames_at
from fusion.merge.cylinder_fit import fit_cylinders
from fusion.merge.hand_ends import hand_anchors
from fusion.merge.kinematic import measurement_targets
from fusion.merge.limb_axis_options import LimbAxisOptions
from fusion.merge.limb_corrections import LimbAxes, joint_offsets, offsets_on_frames
from fusion.merge.pivots import anchors as pivot_anchors
from fusion.merge.pivots import pivots
from fusion.merge.views import CameraViews
from fusion.recording import Recording
from fusion.topology import Landmark, Topology

LIMB_SEGMENTS: tuple[tuple[str, str], ...] = tuple(
    (f"{a}_{side}", f"{b}_{side}") for a, b in (("SHOULDER", "ELBOW"), ("ELBOW", "WRIST"), ("HIP", "KNEE"),
                                                ("KNEE", "ANKLE")) for side in ("LEFT", "RIGHT"))
"""The segments fitted, as (proximal, distal) :class:`~fusion.topology.Landmark` names."""


def limb_segments(topology: Topology) -> np.ndarray:
    """(S, 2) joint indices of the :data:`LIMB_SEGMENTS` that are bones of ``topology``."""
    bones = {(int(p), int(c)) for p, c in topology.bones}
    pairs = [(topology.index(Landmark[a]), topology.index(Landmark[b])) for a, b in LIMB_SEGMENTS
             if Landmark[a] in topology.landmarks and Landmark[b] in topology.landmarks]
    return np.array([p for p in pairs if p in bones], dtype=int).reshape(-1, 2)


def segment_points(points: np.ndarray, skeleton: np.ndarray, topology: Topology, segments: np.ndarray,
                   radii: np.ndarray, options: LimbAxisOptions) -> tuple[np.ndarray, np.ndarray]:
    """Each segment's points of one instant (module docstring).

    Parameters
    ----------
    points : (N, 3) [m] body points, world frame.
    skeleton : (J, 3) [m] the skeleton estimate (NaN joints allowed).
    options : ``max_cloud_points`` of the points (evenly strided) are assigned, at most ``max_points``
        per segment kept.
    segments : (S, 2) from :func:`limb_segments`.
    radii : (S,) [m] the segments' radii (0.1 m where unknown).

    Returns
    -------
    (S, max_points, 3) points (zero where padded) and (S, max_points) bool, which are points.
    """
    S, n_max = len(segments), options.max_points
    P, mask = np.zeros((S, n_max, 3)), np.zeros((S, n_max), bool)
    bones = topology.bones
    ok = np.isfinite(skeleton[bones]).all(axis=(1, 2))
    if points.shape[0] == 0 or not ok.any():
        return P, mask
    if points.shape[0] > options.max_cloud_points:
        points = points[np.linspace(0, points.shape[0] - 1, options.max_cloud_points).astype(int)]
    dist, s = segment_distances(points, skeleton[bones[ok, 0]], skeleton[bones[ok, 1]])
    nearest = np.argmin(dist, axis=1)
    column = {(int(p), int(c)): k for k, (p, c) in enumerate(bones[ok])}
    for q, (a, b) in enumerate(segments):
        k = column.get((int(a), int(b)))
        if k is None:
            continue
        r = radii[q] if np.isfinite(radii[q]) else 0.1
        keep = np.flatnonzero((nearest == k) & (dist[:, k] < r + options.reach_m)
                              & (s[:, k] > options.span[0]) & (s[:, k] < options.span[1]))
        if keep.size > n_max:
            keep = keep[np.linspace(0, keep.size - 1, n_max).astype(int)]
        P[q, :keep.size], mask[q, :keep.size] = points[keep], True
    return P, mask


def _fit_constants(options: LimbAxisOptions) -> dict[str, float]:
    return {"huber_m": options.huber_m, "trim_m": options.trim_m, "iterations": options.iterations}


def _checks(P: np.ndarray, mask: np.ndarray, kept: np.ndarray, rms: np.ndarray, d: np.ndarray, d0: np.ndarray,
            options: LimbAxisOptions) -> np.ndarray:
    n_kept = kept.sum(axis=-1)
    turn = np.degrees(np.arccos(np.clip(np.einsum("...c,...c->...", d, unit(d0)), -1.0, 1.0)))
    return ((n_kept >= options.min_points) & (n_kept >= options.min_inlier_share * np.maximum(mask.sum(axis=-1), 1))
            & (rms <= options.max_rms_m) & (turn <= options.max_turn_deg))


def isolation(targets: np.ndarray, topology: Topology, segments: np.ndarray) -> np.ndarray:
    """(K, S) [m] how far each segment's middle is from the rest of the body: the distance from its
    midpoint to the nearest bone that shares no joint with it, per instant of ``targets`` (K, J, 3);
    NaN where the segment is not measured."""
    bones = topology.bones
    out = np.full(targets.shape[:1] + (len(segments),), np.nan)
    for q, (a, b) in enumerate(segments):
        others = ~np.isin(bones, (a, b)).any(axis=1)
        mid = 0.5 * (targets[:, a] + targets[:, b])
        p, c = targets[:, bones[others, 0]], targets[:, bones[others, 1]]  # (K, B', 3)
        d = c - p
        with np.errstate(invalid="ignore", divide="ignore"):
            s = np.clip(np.einsum("kbc,kbc->kb", mid[:, None] - p, d) / np.einsum("kbc,kbc->kb", d, d), 0.0, 1.0)
        dist = np.linalg.norm(mid[:, None] - (p + s[..., None] * d), axis=-1)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # an instant without any measured bone
            out[:, q] = np.nanmin(dist, axis=1)
    return out


def _twins(segments: np.ndarray, topology: Topology) -> list[int]:
    """Per segment the index of its mirror image in ``segments`` (its own where it has none)."""
    mirror = topology.mirror
    key = {(int(a), int(b)): q for q, (a, b) in enumerate(segments)}
    return [key.get((int(mirror[a]), int(mirror[b])), q) for q, (a, b) in enumerate(segments)]


def radius_instants(iso: np.ndarray, segments: np.ndarray, topology: Topology, n: int) -> list[np.ndarray]:
    """Per segment the instants (indices into ``iso`` (K, S)) its radius is measured at: the ``n``
    instants at which it or its mirror image is most isolated (:func:`isolation`), each side's own."""
    twin = _twins(segments, topology)
    chosen = []
    for q in range(len(segments)):
        both = np.where(np.isnan(iso[:, [q, twin[q]]]), -np.inf, iso[:, [q, twin[q]]])
        rank = np.argsort(-both, axis=None, kind="stable")[:n]
        chosen.append(np.unique(np.unravel_index(rank, both.shape)[0]))
    return chosen


def _radii(points_of, c0: np.ndarray, d0: np.ndarray, segments: np.ndarray, topology: Topology,
           options: LimbAxisOptions, iso: np.ndarray) -> np.ndarray:
    """(S,) [m] per segment the median free-fit radius of the better half (by residual) of the fits
    that pass the checks, at the instants where it or its mirror is most isolated, both sides pooled;
    NaN where no fit passes. ``points_of(ks)`` gives the segments' points (K', S, N, 3) and masks."""
    chosen = radius_instants(iso, segments, topology, options.radius_instants)
    every = np.unique(np.concatenate(chosen)) if chosen else np.zeros(0, int)
    if not every.size:
        return np.full(len(segments), np.nan)
    P, mask = points_of(every)
    K, S = P.shape[:2]
    flat = P.reshape(K * S, *P.shape[2:]), mask.reshape(K * S, -1)
    _, d, r, rms, kept = fit_cylinders(*flat, c0[every].reshape(-1, 3), d0[every].reshape(-1, 3), None,
                                       **_fit_constants(options))
    good = (_checks(*flat, kept, rms, d, d0[every].reshape(-1, 3), options) & (r > 0.01) & (r < 0.2)).reshape(K, S)
    r, rms = r.reshape(K, S), rms.reshape(K, S)
    radii = np.full(S, np.nan)
    for q, twin in enumerate(_twins(segments, topology)):
        pair = sorted({q, twin})
        rows = np.isin(every, chosen[q])
        ok = good[rows][:, pair]
        if ok.any():
            fit_r, fit_e = r[rows][:, pair][ok], rms[rows][:, pair][ok]
            radii[q] = np.median(fit_r[fit_e <= np.median(fit_e)])
    return radii


def _instant_points(recording: Recording, calibration: Calibration, time_s: float, skeleton: np.ndarray,
                    options: LimbAxisOptions, rng: np.random.Generator) -> np.ndarray:
    """(N, 3) [m] every camera's body points of its depth frame nearest ``time_s`` (none near: empty):
    the BODY pixels of a labelled frame; of a frame without labels, the points above the floor (world
    z > 2 cm; ``calibrate`` puts the floor at z = 0) inside the box of the skeleton estimate (J, 3)
    widened by ``4 * reach_m``, which keeps the limbs and drops the room (the limbs' own points are
    picked out by :func:`segment_points`)."""
    points = [np.zeros((0, 3))]
    for labelled in (True, False):
        cams = [c for c in recording.cameras if (c.depth.labels is not None) == labelled]
        if not cams:
            continue
        try:
            frames = frames_at(replace(recording, cameras=cams), calibration, time_s, options.tolerance_s,
                               body_only=labelled, body_radius_m=0.25, floor_clearance_m=0.02, rng=rng)[0]
        except BadInputError:  # no camera of this kind has a frame near the instant
            continue
        for f in frames:
            x = f.points_world
            if not labelled:
                joints = skeleton[np.isfinite(skeleton).all(axis=1)]
                if not joints.size:
                    continue
                lo, hi = joints.min(axis=0) - 4 * options.reach_m, joints.max(axis=0) + 4 * options.reach_m
                x = x[np.all((x >= lo) & (x <= hi), axis=1) & (x[:, 2] > 0.02)]
            points.append(x)
    return np.vstack(points)


def limb_axes(views: CameraViews, recording: Recording, calibration: Calibration,
              options: LimbAxisOptions = LimbAxisOptions(), *, chunk: int = 200) -> LimbAxes:
    """Fit the limb axes at every depth instant of a calibrated recording and the joint corrections
    they give (module docstring).

    Parameters
    ----------
    views : the cameras' skeletons of ``recording`` in the world (:func:`fusion.merge.fuse.camera_views`).
    recording : its depth frames, of the cameras of ``views`` only; the instants are the depth frames
        of the reference camera (else of the first of those cameras with depth) within the views' time span.
    calibration : camera poses and clock offsets.
    chunk : instants fitted at once (memory: about ``chunk * 8 * max_points * 100`` bytes).

    Raises
    ------
    BadInputError
        The topology has no limb segments, no camera of ``views`` has depth frames, or none falls near
        a skeleton frame.
    """
    topo = views.topology
    segments = limb_segments(topo)
    if not len(segments):
        raise BadInputError("limb axes: the joint set has none of the upper arm, forearm, thigh or shank bones")
    cams = [c for c in recording.cameras if c.depth is not None and c.depth.n_frames and c.name in views.names]
    if not cams:
        raise BadInputError(f"limb axes need depth frames, and none of the cameras {', '.join(views.names)} has any; "
                            "record or simulate with depth (sensors.depth_rate_hz > 0), or fuse without limb axes")
    recording = replace(recording, cameras=cams)
    first = next((c for c in cams if c.name == calibration.reference), cams[0])
    times = first.depth.timestamps - calibration.clock_offset_s[first.name]
    times = times[(times >= views.times[0] - options.tolerance_s) & (times <= views.times[-1] + options.tolerance_s)]
    frame = nearest_index(views.times, times)
    near = np.abs(views.times[frame] - times) <= options.tolerance_s
    if not near.any():
        raise BadInputError(f"limb axes: no depth frame of {first.name} lies within {options.tolerance_s} s of a "
                            f"skeleton frame ({views.times[0]:.2f}-{views.times[-1]:.2f} s, reference clock); check "
                            "that the calibration's clock offsets belong to this recording")
    times, frame = times[near], frame[near]
    targets = measurement_targets(views)[1][frame]  # (K, J, 3)
    rng = np.random.default_rng(0)  # frames_at draws only for a selection of body points not used here
    c0 = 0.5 * (targets[:, segments[:, 0]] + targets[:, segments[:, 1]])
    d0 = targets[:, segments[:, 1]] - targets[:, segments[:, 0]]
    measured = np.isfinite(c0).all(axis=-1) & np.isfinite(d0).all(axis=-1)
    c0, d0 = np.where(measured[..., None], c0, 0.0), np.where(measured[..., None], d0, [0.0, 0.0, 1.0])

    def clouds(ks: np.ndarray) -> list[np.ndarray]:
        out = [_instant_points(recording, calibration, times[k], targets[k], options, rng) for k in ks]
        return [x[np.linspace(0, len(x) - 1, options.max_cloud_points).astype(int)]
                if len(x) > options.max_cloud_points else x for x in out]

    def gather(ks: np.ndarray, radii: np.ndarray, points: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        pairs = [segment_points(x, targets[k], topo, segments, radii, options) for x, k in zip(points, ks)]
        return np.stack([p for p, _ in pairs]), np.stack([m for _, m in pairs]) & measured[ks][..., None]

    K, S = times.size, len(segments)
    radii = _radii(lambda ks: gather(ks, np.full(S, np.nan), clouds(ks)), c0, d0, segments, topo, options,
                   isolation(targets, topo, segments))
    centres, directions = np.full((K, S, 3), np.nan), np.full((K, S, 3), np.nan)
    rms, counted = np.full((K, S), np.nan), np.zeros((K, S), bool)
    hands = np.full(targets.shape, np.nan)
    fixed = np.where(np.isfinite(radii), radii, 0.05)
    for start in range(0, K, chunk):
        ks = np.arange(start, min(K, start + chunk))
        points = clouds(ks)
        P, mask = gather(ks, radii, points)
        n = ks.size * S
        c, d, _, e, kept = fit_cylinders(P.reshape(n, *P.shape[2:]), mask.reshape(n, -1), c0[ks].reshape(-1, 3),
                                         d0[ks].reshape(-1, 3), np.tile(fixed, ks.size),
                                         **_fit_constants(options))
        good = _checks(P.reshape(n, *P.shape[2:]), mask.reshape(n, -1), kept, e, d, d0[ks].reshape(-1, 3), options)
        centres[ks], directions[ks] = c.reshape(-1, S, 3), d.reshape(-1, S, 3)
        rms[ks], counted[ks] = e.reshape(-1, S), good.reshape(-1, S) & np.isfinite(radii)[None]
        if options.hands is not None and options.anchor_pull > 0:
            moved = targets[ks] + np.nan_to_num(joint_offsets(targets[ks], segments, centres[ks], directions[ks],
                                                              counted[ks], options.pull))
            hands[ks] = [hand_anchors(x, m, topo, options.hands) for x, m in zip(points, moved)]
    found = pivots(targets, topo, segments, centres, directions, counted, huber_m=options.pivot_huber_m,
                   min_spread=options.pivot_min_spread, min_instants=options.pivot_min_instants,
                   pairs=options.pivots) \
        if options.pivots and options.anchor_pull > 0 else []
    at = np.where(np.isfinite(hands), hands, pivot_anchors(targets, topo, found))
    offsets = joint_offsets(targets, segments, centres, directions, counted, options.pull, at, options.anchor_pull)
    names = tuple(f"{topo.joints[a]}-{topo.joints[b]}" for a, b in segments)
    return LimbAxes(segments, names, radii, times, centres, directions, rms, counted,
                    offsets_on_frames(times, offsets, views.times, options.max_gap_s), tuple(found), at,
                    options.anchor_pull)
