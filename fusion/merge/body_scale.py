"""Whether a tracker's bone lengths move together: a common body scale, measured from its skeletons.

A body-model tracker that fits one template to the person (the Azure Kinect body tracker) reports bone
lengths that rise and fall together, all by one factor per frame, the body's scale; a tracker that
places each joint on its own (the Kinect v2) reports lengths that vary bone by bone. Per camera and
frame the *scale* is the median over the limb bones (:data:`SCALE_BONES`, those the topology has) of
each bone's length over its session median, minus 1. From it:

- ``share``: the part of the bones' relative length variance the scale explains,
  ``1 - var(l / median(l) - 1 - scale) / var(l / median(l))``, pooled over bones and cameras: near 1
  when the lengths move together, near 0 when each bone varies on its own;
- ``sd``: the scale's standard deviation over time (a fraction of the length), median over the cameras;
- ``tau_s``: the lag [s] at which the scale's autocorrelation first falls below ``1/e`` (interpolated),
  median over the cameras: the time constant of an AR(1) with that decay;
- ``shared``: the correlation of two cameras' scales at common times (nearest frames within half a
  period), mean over the camera pairs; NaN with one camera.

:func:`stretch_bones` changes every bone's length by a factor per frame with the least joint
displacement; :func:`without_body_scale` uses it to take a template tracker's scale out of a
recording (the person does not change size), as a replica of the person's motion needs.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from itertools import combinations

import numpy as np

from fusion.calibrate.sync import nearest_index
from fusion.merge.sensor_stats import autocorrelation
from fusion.recording import CameraRecording, Recording
from fusion.skeleton import SkeletonStream
from fusion.topology import Landmark, Topology

_L = Landmark
SCALE_BONES: tuple[tuple[Landmark, Landmark], ...] = tuple(
    (a, b) for s in ("LEFT", "RIGHT") for a, b in (
        (_L[f"SHOULDER_{s}"], _L[f"ELBOW_{s}"]), (_L[f"ELBOW_{s}"], _L[f"WRIST_{s}"]),
        (_L[f"HIP_{s}"], _L[f"KNEE_{s}"]), (_L[f"KNEE_{s}"], _L[f"ANKLE_{s}"])))
"""The limb bones whose lengths give the scale: upper arms, forearms, thighs and shanks."""

SCALE_SHARE = 0.7
"""Least share of the limb bones' length variance a common scale must explain for a tracker to be taken
for a template tracker (measured: 1.000 in every Azure Kinect recording of three people; 0.02-0.44 in
the Kinect v2's KIMORE recordings)."""

NEWTON_STEPS = 3
"""Gauss-Newton steps of :func:`stretch_bones` (each squares the relative length error, 5 % -> 0.3 % -> 1e-5)."""

MAX_DECAY_S = 10.0
"""Longest time constant of the scale looked for [s] (measured: 0.3-0.7 s)."""

MIN_FRAMES = 30
"""Fewest frames with every scale bone reported for a camera to count."""


@dataclass(frozen=True)
class BodyScaleStats:
    """A recording's body scale (see the module docstring): ``share`` and ``sd`` (fractions),
    ``tau_s`` [s], ``shared`` (a correlation; NaN with one camera); all NaN when no camera has
    :data:`MIN_FRAMES` frames with every scale bone."""

    share: float
    sd: float
    tau_s: float
    shared: float


def scale_series(stream: SkeletonStream) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One camera's scale per frame (T,) (NaN where a bone is missing), the bones' relative lengths
    minus 1 (T, B), and the frame times (T,) [s]."""
    top = stream.topology
    pairs = [(top.index(a), top.index(b)) for a, b in SCALE_BONES if a in top.landmarks and b in top.landmarks]
    if not pairs:
        return np.full(len(stream.timestamps), np.nan), np.zeros((len(stream.timestamps), 0)), stream.timestamps
    p = stream.positions
    lengths = np.stack([np.linalg.norm(p[:, a] - p[:, b], axis=-1) for a, b in pairs], axis=1)
    ok = np.all(np.isfinite(lengths), axis=1)
    if not ok.any():
        return np.full(len(ok), np.nan), np.full(lengths.shape, np.nan), stream.timestamps
    rel = lengths / np.median(lengths[ok], axis=0) - 1
    rel[~ok] = np.nan
    return np.where(ok, np.median(rel, axis=1), np.nan), rel, stream.timestamps


def _decay_time(x: np.ndarray, dt: float) -> float:
    """Lag [s] at which the autocorrelation of ``x`` (T,) first falls below 1/e (interpolated), searched
    over the first half of the series and at most :data:`MAX_DECAY_S`; NaN when it does not fall."""
    acf = autocorrelation(x - x.mean(), min(len(x) // 2 - 1, int(MAX_DECAY_S / dt)))
    below = np.flatnonzero(acf < 1 / np.e)
    if not below.size:
        return np.nan
    k = below[0]
    return float(dt * (k - 1 + (acf[k - 1] - 1 / np.e) / (acf[k - 1] - acf[k])))


def _camera_series(recording: Recording) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """:func:`scale_series` of every camera with a skeleton, by name."""
    return {c.name: scale_series(c.skeleton) for c in recording.cameras if c.skeleton is not None}


def _share(series: Iterable[tuple[np.ndarray, np.ndarray, np.ndarray]]) -> float:
    """The share of the bones' relative length variance the scale explains, pooled over the cameras
    with :data:`MIN_FRAMES` complete frames (NaN: none)."""
    residual = total = 0.0
    for scale, rel, _ in series:
        ok = np.isfinite(scale)
        if ok.sum() >= MIN_FRAMES:
            residual += float(np.sum(np.var(rel[ok] - scale[ok, None], axis=0)))
            total += float(np.sum(np.var(rel[ok], axis=0)))
    return 1 - residual / total if total > 0 else np.nan


def body_scale_stats(recording: Recording) -> BodyScaleStats:
    """The body scale of every camera of ``recording`` (module docstring)."""
    per_camera = list(_camera_series(recording).values())
    series, sds, taus = [], [], []
    for scale, _, t in per_camera:
        ok = np.isfinite(scale)
        if ok.sum() < MIN_FRAMES:
            continue
        sds.append(float(np.std(scale[ok])))
        # the autocorrelation of the frames with every bone (gaps closed: a few dropped frames)
        taus.append(_decay_time(scale[ok], float(np.median(np.diff(t)))))
        series.append((t[ok], scale[ok]))
    if not series:
        return BodyScaleStats(np.nan, np.nan, np.nan, np.nan)
    return BodyScaleStats(float(_share(per_camera)), float(np.median(sds)),
                          float(np.nanmedian(taus)) if np.isfinite(taus).any() else np.nan, _shared(series))


def _shared(series: Sequence[tuple[np.ndarray, np.ndarray]]) -> float:
    """Mean over camera pairs of the correlation of their scales at the nearest common frames."""
    corrs = []
    for (t1, x1), (t2, x2) in combinations(series, 2):
        j = nearest_index(t2, t1)
        near = np.abs(t2[j] - t1) <= 0.5 * np.median(np.diff(t1))
        if near.sum() >= MIN_FRAMES:
            corrs.append(float(np.corrcoef(x1[near], x2[j[near]])[0, 1]))
    return float(np.mean(corrs)) if corrs else np.nan


@dataclass(frozen=True)
class _BonePlan:
    """Gaussian elimination of the bones' Gram matrix ``A A^T`` without fill-in.

    Two bones interact when they share a joint. Eliminating the bones leaf first (deepest child joint
    first), a bone's remaining neighbours all share its parent joint, so they already interact: the
    elimination creates no entry outside that pattern, and each step is a few vector operations over
    all frames at once.
    """

    incidence: np.ndarray  # (B, J) +1 at a bone's child joint, -1 at its parent
    signs: np.ndarray  # (B, B) incidence @ incidence.T: 2 on the diagonal, +-1 for bones sharing a joint
    pairs: tuple[np.ndarray, np.ndarray]  # the (B, B) entries that can be non-zero
    order: tuple[int, ...]  # elimination order
    later: tuple[np.ndarray, ...]  # per bone, its neighbours eliminated after it

    @staticmethod
    def of(parents: np.ndarray) -> _BonePlan:
        child = np.flatnonzero(parents >= 0)
        incidence = np.zeros((len(child), len(parents)))
        incidence[np.arange(len(child)), child] = 1.0
        incidence[np.arange(len(child)), parents[child]] = -1.0
        signs = incidence @ incidence.T
        depth = np.zeros(len(parents), dtype=int)
        for j in range(len(parents)):
            k = j
            while parents[k] >= 0:
                depth[j], k = depth[j] + 1, parents[k]
        order = np.argsort(-depth[child], kind="stable")
        rank = np.argsort(order)
        later = tuple(np.flatnonzero((signs[b] != 0) & (rank > rank[b])) for b in range(len(child)))
        return _BonePlan(incidence, signs, np.nonzero(signs), tuple(int(b) for b in order), later)

    def solve(self, u: np.ndarray, ridge: np.ndarray, rhs: np.ndarray) -> np.ndarray:
        """(T, B) ``x`` of ``(signs * u u^T + diag(ridge)) x = rhs`` per frame, for (T, B, 3) bone
        directions ``u`` and (T, B) ``ridge`` and ``rhs``."""
        i, j = self.pairs
        gram = np.zeros(self.signs.shape + (u.shape[0],))
        gram[i, j] = self.signs[i, j, None] * np.einsum("tpk,tpk->pt", u[:, i], u[:, j])
        b = np.arange(self.signs.shape[0])
        gram[b, b] += ridge.T
        r = rhs.T.copy()
        for k in self.order:
            n = self.later[k]
            if n.size:
                ratio = gram[n, k] / gram[k, k]
                gram[n[:, None], n] -= ratio[:, None] * gram[k, n][None]
                r[n] -= ratio * r[k]
        x = np.zeros_like(r)
        for k in reversed(self.order):
            n = self.later[k]
            x[k] = (r[k] - np.einsum("nt,nt->t", gram[k, n], x[n])) / gram[k, k]
        return x.T


def stretch_bones(positions: np.ndarray, topology: Topology, scale: np.ndarray) -> np.ndarray:
    """Every bone's length times the frame's ``scale`` by the smallest joint displacement.

    Per frame, the displacement ``d`` (J, 3) of least norm whose change of each bone's length along the
    bone (``(d_child - d_parent) . u``) is what the length lacks, ``d = A^T (A A^T)^-1 delta``, repeated
    :data:`NEWTON_STEPS` times (Gauss-Newton on the bone constraints from the given pose). No joint is
    pinned: the body keeps its centre, as a tracker that fits its template to the depth it sees places
    the joints as near to the data as the template's lengths allow. A bone with a missing (NaN) end is
    left out; missing joints stay missing.

    Parameters
    ----------
    positions : np.ndarray
        (T, J, 3) [m] joints (NaN: missing).
    topology : Topology
        Joint set (parents).
    scale : np.ndarray
        (T,) the factor of every bone length per frame (NaN: 1).

    Returns
    -------
    np.ndarray
        (T, J, 3) [m] the stretched joints.
    """
    parents = np.asarray(topology.parents)
    child = np.flatnonzero(parents >= 0)
    plan = _BonePlan.of(parents)
    missing = ~np.all(np.isfinite(positions), axis=-1)
    out = np.where(missing[..., None], 0.0, positions)
    absent = (missing[:, child] | missing[:, parents[child]]).astype(float)  # (T, B): bones left out
    factor = np.where(np.isfinite(scale), scale, 1.0)[:, None]
    target = factor * np.linalg.norm(out[:, child] - out[:, parents[child]], axis=-1)
    for _ in range(NEWTON_STEPS):
        bone = out[:, child] - out[:, parents[child]]
        length = np.linalg.norm(bone, axis=-1)
        u = bone / np.maximum(length, 1e-9)[..., None] * (1 - absent)[..., None]
        # a left-out bone's row is the identity (its multiplier 0); 1e-9: zero-length bones
        multipliers = plan.solve(u, absent + 1e-9, (target - length) * (1 - absent))
        step = multipliers[..., None] * u  # (T, B, 3)
        out = out + np.einsum("bj,tbk->tjk", plan.incidence, step, optimize=True)
    return np.where(missing[..., None], np.nan, out)


def without_body_scale(recording: Recording) -> Recording:
    """``recording`` with a template tracker's body scale taken out of every camera's skeletons (each
    frame's bones stretched by ``1 / (1 + scale)``); unchanged when the common scale explains less than
    :data:`SCALE_SHARE` of the bones' length variance (the bones vary each on its own)."""
    series = _camera_series(recording)
    if not _share(series.values()) >= SCALE_SHARE:
        return recording
    cameras = []
    for cam in recording.cameras:
        if cam.skeleton is not None:
            stretched = stretch_bones(cam.skeleton.positions, cam.skeleton.topology, 1 / (1 + series[cam.name][0]))
            skeleton = SkeletonStream(cam.skeleton.topology, cam.skeleton.timestamps, stretched, cam.skeleton.states)
            cam = CameraRecording(cam.name, cam.intrinsics, skeleton, cam.depth)
        cameras.append(cam)
    return Recording(tuple(cameras), recording.metadata)
