"""Fit the tracker's arm and trunk biases (:mod:`sim.tracker_arm_bias`, :mod:`sim.tracker_trunk_bias`) to a
real Kinect against an optical reference.

Per episode the Kinect is aligned with the reference (:func:`fusion.merge.episode_alignment.align_episodes`),
the reference is resampled at the Kinect's frame times, and for the moving arm each of its shoulder,
elbow and wrist joints gives an offset ``kinect - reference`` [m] in the reference's swing frames, with
the reference's elevation and forearm direction; the pelvis, spine-mid and spine-shoulder joints give
theirs in the reference's thorax frame, with the higher arm's elevation. Per person the offsets at the knots
(:data:`sim.tracker_arm_bias.KNOTS_DEG`, interpolated by the quadratic through them), for the arm with
the forearm's terms (:data:`sim.tracker_arm_bias.FOREARM_TERMS`), are a least-squares fit over all of
that person's frames (frames whose offset exceeds :data:`GROSS_M`, tracking failures,
left out); the population is their mean and the principal modes of the people's deviations from it,
scaled by ``1 / sqrt(n - 1)`` so that ``mean + sum_k z_k mode_k`` has the people's sample covariance
(:class:`sim.tracker_arm_bias.KnotBias`).

What this sees and what it cannot: the offset is measured after the rigid alignment, which absorbs the
part of a constant offset that a rigid motion of the whole skeleton can explain; the simulation is
judged through the same alignment. One Kinect per episode: the body-model and view-dependent parts
are not separated (the view bias of the profile is kept as it was fitted, from cross-camera residuals).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from joblib import Parallel, delayed

from fusion.errors import BadInputError
from fusion.io.formats.ui_prmd import read_ui_prmd_kinect
from fusion.merge.episode_alignment import align_episodes, resample
from fusion.topology import KINECT_V2, Landmark
from fusion.transforms import apply
from scenarios.sensors.angle_clocks import ClockRatios
from scenarios.sensors.angle_replica import replica_trajectory
from scenarios.sensors.angle_validate import Episode
from sim.sensor_profile import SensorProfile
from sim.tracker_arm_bias import ARM_JOINTS, ArmBias, arm_frames
from sim.tracker_trunk_bias import TRUNK_JOINTS, TrunkBias, trunk_frames

GROSS_M = 0.3
"""Offsets beyond this [m] are tracking failures, not the landmark's place: left out of the fit."""


@dataclass(frozen=True, eq=False)
class EpisodeOffsets:
    """One episode's arm offsets.

    Attributes
    ----------
    subject : whose episode.
    basis : (T, P) the arm bias's weights (:meth:`sim.tracker_arm_bias.ArmFrames.basis`) at the reference's
        pose per Kinect frame.
    offsets : (T, 3, 3) [m] per frame and joint (:data:`~sim.tracker_arm_bias.ARM_JOINTS`) the
        swing-frame offset ``kinect - reference``; NaN where either is missing.
    trunk_basis : (T, 3) the knots' weights at the reference's higher arm elevation.
    trunk_offsets : (T, 3, 3) [m] per frame and joint (:data:`~sim.tracker_trunk_bias.TRUNK_JOINTS`) the
        thorax-frame offset ``kinect - reference``; NaN where either is missing.
    """

    subject: str
    basis: np.ndarray
    offsets: np.ndarray
    trunk_basis: np.ndarray
    trunk_offsets: np.ndarray


def episode_offsets(episode: Episode, rate_ratio: float = 1.0) -> EpisodeOffsets | None:
    """The arm offsets of one episode (module docstring), the Kinect's clock running ``rate_ratio``
    times the reference's (:func:`~scenarios.sensors.angle_clocks.clock_ratios`); None when the
    alignment fails."""
    _, reference = replica_trajectory(episode.vicon)
    kinect = read_ui_prmd_kinect(episode.kinect).cameras[0].skeleton
    alignment = align_episodes(reference, kinect, rate_ratios=(rate_ratio,))
    if not alignment.ok:
        return None
    t = alignment.rate_ratio * kinect.timestamps + alignment.shift_s
    ref = np.stack([np.stack([resample(reference.timestamps, reference.positions[:, j, k], t) for k in range(3)], -1)
                    for j in range(KINECT_V2.n_joints)], axis=1)
    seen = apply(alignment.T_vicon_kinect, kinect.positions)
    side = alignment.side
    frames = arm_frames(ref, KINECT_V2)
    idx = [(KINECT_V2.index(Landmark[f"{j.upper()}_{side.upper()}"]),
            kinect.topology.index(Landmark[f"{j.upper()}_{side.upper()}"])) for j in ARM_JOINTS]
    diff = np.stack([seen[:, k] - ref[:, r] for r, k in idx], axis=1)  # (T, 3, 3) world
    local = np.einsum("tjka,tjk->tja", frames.frames[side], diff)
    trunk = trunk_frames(ref, KINECT_V2)
    kdx = [kinect.topology.index(Landmark[j.upper()]) for j in TRUNK_JOINTS]
    trunk_local = np.einsum("tka,tjk->tja", trunk.frames, seen[:, kdx] - ref[:, trunk.joints])
    return EpisodeOffsets(episode.subject, frames.basis(side), local, trunk.basis, trunk_local)


def collect_offsets(episodes: Sequence[Episode], *, rate_ratios: ClockRatios | None = None, jobs: int = 1,
                    progress: Callable[[int], None] | None = None) -> list[EpisodeOffsets]:
    """:func:`episode_offsets` of each episode (those that align), ``jobs`` at once; ``rate_ratios``
    gives each episode's clock ratio (default 1)."""
    tick = progress or (lambda n: None)
    out = []
    for result in Parallel(n_jobs=jobs, return_as="generator")(
            delayed(episode_offsets)(e, rate_ratios.of(e) if rate_ratios else 1.0) for e in episodes):
        if result is not None:
            out.append(result)
        tick(1)
    return out


def _knot_fit(basis: np.ndarray, local: np.ndarray, joints: Sequence[str], what: str) -> np.ndarray:
    """(J, P, 3) [m] least-squares values (joint, term, axis) of offsets ``local`` (T, J, 3) [m] with
    the terms' weights ``basis`` (T, P), gross offsets left out."""
    coefficients = np.zeros((len(joints), basis.shape[1], 3))
    for j, name in enumerate(joints):
        keep = np.isfinite(local[:, j]).all(axis=-1) & np.isfinite(basis).all(axis=-1)
        keep &= np.linalg.norm(np.nan_to_num(local[:, j]), axis=-1) <= GROSS_M
        if keep.sum() < 3 * basis.shape[1]:
            raise BadInputError(f"too few frames with a {name} offset ({int(keep.sum())}) to fit the {what} bias")
        coefficients[j], *_ = np.linalg.lstsq(basis[keep], local[keep, j], rcond=None)
    return coefficients


def person_coefficients(offsets: Sequence[EpisodeOffsets]) -> np.ndarray:
    """(3, P, 3) [m] least-squares arm offsets (joint, term, axis) over the episodes' frames."""
    return _knot_fit(np.concatenate([o.basis for o in offsets]), np.concatenate([o.offsets for o in offsets]),
                     ARM_JOINTS, "arm")


def person_trunk_coefficients(offsets: Sequence[EpisodeOffsets]) -> np.ndarray:
    """(3, 3, 3) [m] least-squares trunk offsets (joint, knot, axis) over the episodes' frames."""
    return _knot_fit(np.concatenate([o.trunk_basis for o in offsets]),
                     np.concatenate([o.trunk_offsets for o in offsets]), TRUNK_JOINTS, "trunk")


@dataclass(frozen=True, eq=False)
class ArmBiasFit:
    """The arm and trunk biases of a population of people.

    Attributes
    ----------
    per_person : person -> (3, P, 3) [m] arm offsets at the knots and per forearm term.
    arm_bias : mean and modes of variation between the people.
    episodes : person -> episodes used.
    per_person_trunk : person -> (3, 3, 3) [m] trunk offsets at the knots.
    trunk_bias : mean and modes of variation between the people.
    """

    per_person: Mapping[str, np.ndarray]
    arm_bias: ArmBias
    episodes: Mapping[str, int]
    per_person_trunk: Mapping[str, np.ndarray]
    trunk_bias: TrunkBias


def person_modes(people: np.ndarray) -> np.ndarray:
    """(K, 3, P, 3) [m] the principal modes of the people's offsets ``people`` (n, 3, P, 3) about their
    mean, each scaled by its singular value / sqrt(n - 1); the modes of a zero singular value dropped
    (K <= n - 1)."""
    n = people.shape[0]
    deviations = (people - people.mean(axis=0)).reshape(n, -1)
    _, s, vt = np.linalg.svd(deviations, full_matrices=False)
    keep = s > max(1e-9 * float(s.max(initial=0.0)), 1e-12)  # 1e-12 m: rounding of the mean, not a person
    return (s[keep, None] * vt[keep] / np.sqrt(n - 1)).reshape((-1, *people.shape[1:]))


def fit_arm_bias(offsets: Sequence[EpisodeOffsets], *, exclude: str | None = None) -> ArmBiasFit:
    """The population's arm and trunk biases from the episodes' offsets (module docstring), without
    ``exclude``'s.

    Raises
    ------
    BadInputError
        Fewer than two people remain (no between-person spread can be measured).
    """
    people = sorted({o.subject for o in offsets} - {exclude})
    if len(people) < 2:
        raise BadInputError(f"the arm bias needs episodes of two people or more, got {len(people)} ({', '.join(people)})")
    mine = {p: [o for o in offsets if o.subject == p] for p in people}
    arm = {p: person_coefficients(mine[p]) for p in people}
    trunk = {p: person_trunk_coefficients(mine[p]) for p in people}
    arms, trunks = np.stack(list(arm.values())), np.stack(list(trunk.values()))
    return ArmBiasFit(arm, ArmBias(arms.mean(axis=0), person_modes(arms)), {p: len(mine[p]) for p in people},
                      trunk, TrunkBias(trunks.mean(axis=0), person_modes(trunks)))


YAW_SCALED_SOURCE = (
    "not scaled by the yaw multiplier: the fitting people faced the Kinect, so how the offsets grow seen from the "
    "side or behind is not measured; scaled (up to 3 times), the shoulders' medial offsets crossed the shoulders of "
    "skeletons seen from behind and inverted the back-facing detection (ring6 seed 7: a camera calibrated 180 deg off)")


FIT_PARTS = ("arm", "trunk")
"""The biases a fit can give a profile."""


def with_arm_bias(profile: SensorProfile, fit: ArmBiasFit, source: str,
                  parts: Sequence[str] = FIT_PARTS) -> SensorProfile:
    """``profile`` with the fitted biases of ``parts`` (of :data:`FIT_PARTS`; the others as the profile
    has them) and their provenance (``source``: the data set and command)."""
    people = ", ".join(f"{p} ({n} episodes)" for p, n in fit.episodes.items())
    modes = "principal modes of the people's deviations from the mean, scaled to their sample covariance"
    provenance = dict(profile.provenance)
    for part, what in (("arm", "swing-frame offsets kinect - reference of the moving arm's shoulder, elbow and "
                               "wrist at the elevation knots and per unit of the forearm's forward and "
                               "lateral direction"),
                       ("trunk", "thorax-frame offsets kinect - reference of the pelvis, spine-mid and "
                                 "spine-shoulder at the knots of the higher arm's elevation")):
        if part not in parts:
            continue
        name = f"{part}_bias"
        how = (f"fitted against an optical reference ({source}; people {people}): per person the least-squares "
               f"{what} (scenarios.sensors.fit_arm_bias)")
        provenance.update({f"tracker.{name}.mean_m": f"{how}; mean over the people",
                           f"tracker.{name}.person_modes_m": f"{how}; {modes}"})
    fitted = {f"{p}_bias": getattr(fit, f"{p}_bias") for p in parts}
    if "arm" in parts:
        provenance["tracker.arm_bias.yaw_scaled"] = YAW_SCALED_SOURCE
    tracker = dataclasses.replace(profile.tracker, **fitted)
    return dataclasses.replace(profile, tracker=tracker, provenance=provenance)
