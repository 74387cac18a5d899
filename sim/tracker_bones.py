"""The lengths of a tracker's bones: held toward their session median, and scaled together.

Bone rigidity (:attr:`sim.tracker_noise.GroupNoise.bone_rigidity`) pulls each reported bone length
toward its session median, as a tracker with a fixed-length body model moves a glitching joint along
its bone rather than off it. The body scale multiplies every reported bone length by one factor per
frame: a tracker that fits one body template to the person (the Azure Kinect body tracker; see
:mod:`fusion.merge.body_scale` for the measurement) reports all bone lengths rising and falling
together. The simulated factor of a camera's frame at time ``t`` is

    s(t) = 1 + sd * (sqrt(shared) * z_session(t) + sqrt(1 - shared) * z_camera(t)),

``sd``, ``shared`` and the time constant ``tau`` from :class:`sim.tracker_noise.TrackerNoise`
(``body_scale_sd``, ``body_scale_shared``, ``body_scale_tau_s``). Both ``z`` are stationary unit
processes with the autocorrelation ``exp(-|dt| / tau)``: ``z_camera`` an AR(1) over the camera's frames,
``z_session`` shared by the session's cameras (which see the same body) and defined at any time, as a
sum of :data:`N_WAVES` cosines whose angular frequencies are drawn from the Cauchy law of scale
``1 / tau`` (the spectrum of that autocorrelation), so that cameras with their own clocks sample one
process. The bones are stretched by the smallest joint displacement
(:func:`fusion.merge.body_scale.stretch_bones`): the
cross-camera residual of the real tracker does not follow the difference of the two cameras' scales as
a body grown from its feet or its pelvis would (regression slopes -0.15 to 0.27 on six sessions of three
people, where such a body gives 1); the least-norm stretch would add 2.0-4.5 mm rms to residuals of
19-34 mm rms, too little for those sessions to show.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fusion.errors import BadInputError
from fusion.topology import Topology
from sim.tracker_noise import TrackerNoise, ar1

N_WAVES = 256
"""Cosines of the shared process (its distribution is Gaussian to within a few per cent)."""

MAX_DEVIATION = 4.0
"""Largest magnitude of the standardised scale (keeps the factor positive for any ``sd`` <= 0.2)."""


@dataclass(frozen=True, eq=False)
class ScaleWaves:
    """The shared process of one session: angular frequencies [rad/s] and phases [rad], (N_WAVES,) each."""

    omega: np.ndarray
    phase: np.ndarray

    def __call__(self, t: np.ndarray) -> np.ndarray:
        """The unit process at times ``t`` (T,) [s]: (T,)."""
        t = np.asarray(t, dtype=float)
        out = np.zeros(t.shape)
        for start in range(0, len(t), 4096):  # bounded memory for long sessions
            chunk = t[start:start + 4096]
            out[start:start + 4096] = np.cos(np.outer(chunk, self.omega) + self.phase).sum(axis=1)
        return out * np.sqrt(2.0 / len(self.omega))


def draw_waves(tau_s: float, rng: np.random.Generator) -> ScaleWaves:
    """A session's shared process with time constant ``tau_s`` [s]."""
    if not tau_s > 0:
        raise BadInputError(f"the body scale's time constant must be positive, got {tau_s}")
    return ScaleWaves(np.abs(rng.standard_cauchy(N_WAVES)) / tau_s, rng.uniform(0.0, 2 * np.pi, N_WAVES))


def session_waves(noise: TrackerNoise, seq: np.random.SeedSequence) -> ScaleWaves | None:
    """The shared process of a session whose systematic draws come from ``seq`` (drawn from a child of
    it, so the other draws are unchanged); None for a tracker without a body scale."""
    if noise.body_scale_sd == 0:
        return None
    return draw_waves(noise.body_scale_tau_s, np.random.default_rng(seq.spawn(1)[0]))


def body_scale(timestamps: np.ndarray, noise: TrackerNoise, shared: np.ndarray | None,
               rng: np.random.Generator) -> np.ndarray:
    """(T,) scale factor of one camera's frames at ``timestamps`` (T,) [s]; ``shared`` (T,) the session's
    shared process at those frames' true times (:class:`ScaleWaves`; None: this camera draws its own
    from ``rng``)."""
    ts = np.asarray(timestamps, dtype=float)
    if shared is None:
        shared = draw_waves(noise.body_scale_tau_s, rng)(ts)
    a = float(np.exp(-np.median(np.diff(ts)) / noise.body_scale_tau_s)) if len(ts) > 1 else 0.0
    c = noise.body_scale_shared
    z = np.sqrt(c) * np.asarray(shared, dtype=float) + np.sqrt(1 - c) * ar1((len(ts),), a, rng)
    return 1.0 + noise.body_scale_sd * np.clip(z, -MAX_DEVIATION, MAX_DEVIATION)


def hold_bone_lengths(positions: np.ndarray, reported: np.ndarray, topology: Topology,
                      rigidity: float | np.ndarray, *, truth: np.ndarray | None = None,
                      shared: float = 0.0) -> np.ndarray:
    """Pull every bone's length toward its session median, root outward.

    Each child is placed from its (already moved) parent along the reported bone direction at length
    ``(1 - r) * L + r * M`` (``r`` the child's rigidity), so the change carries on to its descendants.
    ``M`` is ``(1 - s) * median(L) + s * median(L_true)``: with ``shared`` ``s`` > 0 the person's own
    length in ``truth`` takes that share of the camera's median.

    Parameters
    ----------
    positions : np.ndarray
        (T, J, 3) [m] reported joints (any frame).
    reported : np.ndarray
        (T, J) bool, joints reported; the medians use frames where both ends are reported.
    topology : Topology
        Joint set (parents).
    rigidity : float or np.ndarray
        In [0, 1], one for all bones or (J,) per child joint.
    truth : np.ndarray, optional
        (T, J, 3) [m] the true joints, the person's own bone lengths (needed when ``shared`` > 0).
    shared : float
        In [0, 1], the share of the person's own length in the length held.

    Returns
    -------
    np.ndarray
        (T, J, 3) [m] the adjusted joints.
    """
    parents = np.asarray(topology.parents)
    r = np.broadcast_to(np.asarray(rigidity, dtype=float), parents.shape)
    depth = np.zeros(len(parents), dtype=int)
    for j in range(len(parents)):
        p = parents[j]
        while p >= 0:
            depth[j] += 1
            p = parents[p]
    out = positions.copy()
    for j in sorted(np.flatnonzero(parents >= 0), key=lambda i: depth[i]):
        p = parents[j]
        bone = positions[:, j] - positions[:, p]
        length = np.linalg.norm(bone, axis=-1)
        both = reported[:, j] & reported[:, p]
        if not np.any(both):
            out[:, j] = out[:, p] + bone
            continue
        held = np.median(length[both])
        if shared > 0:
            held = (1 - shared) * held + shared * np.nanmedian(np.linalg.norm(truth[:, j] - truth[:, p], axis=-1))
        target = (1 - r[j]) * length + r[j] * held
        out[:, j] = out[:, p] + bone * (target / np.maximum(length, 1e-9))[:, None]
    return out
