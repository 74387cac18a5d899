"""The subject's size from a landmark trajectory: stature and segment-length multipliers.

Each segment's length in the data is the median over every frame (and both sides) where both of
its joints are present; robust to tracker outliers and gaps. The humanoid's own length of the same
segment (between the same two sites, neutral stance) at the reference stature gives a ratio per
segment.

The stature scale comes from the standing chain ankle -> knee -> hip -> pelvis -> spine-shoulder ->
head centre (shank, thigh, trunk and the head segment, which has no multiplier): the reference
stature times the chain's measured length over the humanoid's (with fewer than two of those
segments in the data, the median ratio of all segments instead). Each segment's multiplier
(:class:`sim.anthropometry.Anthropometry`) is its ratio over that scale; two passes rebuild the
humanoid with the estimate and correct the multipliers for the parts of a segment that do not
scale with its multiplier (the sternal notch's offset from the trunk's axis). The stature reported
(:attr:`ScaleEstimate.stature_m`) is the standing height of the body so built, multipliers
included.

Segments: upper arm (shoulder-elbow), forearm (elbow-wrist), thigh (hip-knee), shank (knee-ankle),
trunk (pelvis-spine shoulder); head (spine shoulder-head centre) for the stature only.

The segment lengths are matched exactly; the stature is only as good as the tracker's bones are
anatomical, and the parts of the body no landmark measures (sole to ankle, head centre to vertex)
scale with the chain. On the humanoid's own landmarks with segment multipliers 0.75-1.25 the
stature comes within 5 % (exact with uniform proportions). Measured on the shared samples
(``mocap-bench retarget-report``): fused two-camera Azure Kinect sessions (``azure_2cam`` 01 and 06)
give 1.67 and 1.64 m, every multiplier within 0.96-1.04. Single Kinect v2 recordings (``kimore``)
have limb bones far shorter than an adult's joint-centre segments (thigh and shank 0.29-0.41 m
against 0.43 m at 1.75 m, upper arm 0.23-0.28 m against 0.33 m) but a trunk of adult length: their
first person gives 1.53 and 1.36 m in exercises 1 and 2, the second 1.47 and 1.65 m (trunk
multipliers 1.12-1.22). The tracker's bones themselves differ by about 10 % between one person's
two exercises, and so does the estimate. The median segment ratio would set the stature scale
from the short limbs there (1.25-1.32 m for the first person) and stretch the trunk by up to 1.41.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from fusion.errors import BadInputError
from fusion.io.mocap import LandmarkTrajectory
from fusion.topology import Landmark
from sim.anthropometry import HEIGHT_RANGE_M, MULTIPLIER_RANGE, Anthropometry, Build
from sim.coordinates import COORDINATES
from sim.humanoid_model import build_humanoid

SEGMENTS: dict[str, tuple[tuple[Landmark, Landmark], ...]] = {
    "upper_arm": ((Landmark.SHOULDER_LEFT, Landmark.ELBOW_LEFT), (Landmark.SHOULDER_RIGHT, Landmark.ELBOW_RIGHT)),
    "forearm": ((Landmark.ELBOW_LEFT, Landmark.WRIST_LEFT), (Landmark.ELBOW_RIGHT, Landmark.WRIST_RIGHT)),
    "thigh": ((Landmark.HIP_LEFT, Landmark.KNEE_LEFT), (Landmark.HIP_RIGHT, Landmark.KNEE_RIGHT)),
    "shank": ((Landmark.KNEE_LEFT, Landmark.ANKLE_LEFT), (Landmark.KNEE_RIGHT, Landmark.ANKLE_RIGHT)),
    "trunk": ((Landmark.PELVIS, Landmark.SPINE_SHOULDER),),
}
"""Segment (an :class:`Anthropometry` multiplier) -> the landmark pairs that measure it."""

HEAD = "head"
_MEASURED = SEGMENTS | {HEAD: ((Landmark.SPINE_SHOULDER, Landmark.HEAD),)}
"""Every measured segment: the multipliers' and the head segment (spine shoulder to head centre)."""

STATURE_CHAIN = ("shank", "thigh", "trunk", HEAD)
"""The segments of the standing chain from the ankle to the head centre, which sets the stature scale."""

_REFERENCE_HEIGHT_M = 1.75


@dataclass(frozen=True)
class ScaleEstimate:
    """The subject's size as measured from a trajectory.

    Attributes
    ----------
    anthropometry : the scaled subject.
    segment_lengths_m : segment -> median length in the data [m] (segments never seen left out).
    frames : segment -> number of measurements behind the median.
    clipped : segments whose multiplier was clipped to :data:`sim.anthropometry.MULTIPLIER_RANGE`.
    """

    anthropometry: Anthropometry
    segment_lengths_m: dict[str, float]
    frames: dict[str, int]
    clipped: tuple[str, ...]

    @property
    def stature_m(self) -> float:
        """Standing height of the scaled humanoid (head top above the soles), metres."""
        return self.anthropometry.dimensions.stature


def measured_lengths(trajectory: LandmarkTrajectory) -> tuple[dict[str, float], dict[str, int]]:
    """Median length of each segment (and the head segment) over the trajectory, metres, and the count
    of measurements."""
    topo, pos = trajectory.topology, trajectory.positions
    lengths, counts = {}, {}
    for seg, pairs in _MEASURED.items():
        values = np.concatenate([np.linalg.norm(pos[:, topo.index(a)] - pos[:, topo.index(b)], axis=-1)
                                 for a, b in pairs])
        values = values[np.isfinite(values)]
        if values.size:
            lengths[seg], counts[seg] = float(np.median(values)), int(values.size)
    return lengths, counts


def _model_lengths(anthro: Anthropometry, trajectory: LandmarkTrajectory) -> dict[str, float]:
    """Each segment's length on the humanoid in the neutral stance, metres."""
    topo = trajectory.topology
    joints = build_humanoid(anthro).joint_positions(np.zeros((1, len(COORDINATES))), topo)[0]
    return {seg: float(np.mean([np.linalg.norm(joints[topo.index(a)] - joints[topo.index(b)]) for a, b in pairs]))
            for seg, pairs in _MEASURED.items()}


def estimate_anthropometry(trajectory: LandmarkTrajectory, *, build: Build = Build.AVERAGE,
                           units_option: str = "units") -> ScaleEstimate:
    """Stature and segment multipliers of the subject of a trajectory.

    Parameters
    ----------
    trajectory : LandmarkTrajectory
        (T, J, 3) positions [m].
    build : Build
        Girth of the humanoid (landmarks carry no girth information).
    units_option : str
        Name of the option that sets the source's length unit, quoted in the error message.

    Returns
    -------
    ScaleEstimate

    Raises
    ------
    BadInputError
        If fewer than two segments are ever seen, or the estimated stature lies outside
        :data:`sim.anthropometry.HEIGHT_RANGE_M` (typically a source in the wrong unit).
    """
    lengths, counts = measured_lengths(trajectory)
    if len(lengths.keys() & SEGMENTS.keys()) < 2:
        raise BadInputError(f"{trajectory.source or 'the trajectory'}: only {sorted(lengths) or 'no'} segment(s) "
                            f"seen; the subject's size needs at least two of {', '.join(SEGMENTS)}")
    reference = _model_lengths(Anthropometry(height_m=_REFERENCE_HEIGHT_M, build=build), trajectory)
    chain = [seg for seg in STATURE_CHAIN if seg in lengths]
    if len(chain) >= 2:
        scale = sum(lengths[seg] for seg in chain) / sum(reference[seg] for seg in chain)
    else:
        scale = float(np.median([lengths[seg] / reference[seg] for seg in lengths]))
    ratios = {seg: lengths[seg] / reference[seg] for seg in SEGMENTS if seg in lengths}
    height = _REFERENCE_HEIGHT_M * scale
    lo, hi = HEIGHT_RANGE_M
    if not lo <= height <= hi:
        raise BadInputError(
            f"{trajectory.source or 'the trajectory'}: the estimated stature {height:.3g} m is implausible "
            f"(accepted {lo} .. {hi} m; median segment lengths "
            + ", ".join(f"{k} {v:.3g}" for k, v in lengths.items())
            + f" in the file's unit as metres): the source is probably not in metres; set its unit with the "
            f"'{units_option}' option")
    mults = {seg: r / scale for seg, r in ratios.items()}
    anthro = Anthropometry(height_m=height, build=build)
    clipped: set[str] = set()
    for _ in range(2):
        bounded = {k: float(np.clip(v, *MULTIPLIER_RANGE)) for k, v in mults.items()}
        clipped |= {k for k in mults if bounded[k] != mults[k]}
        anthro = replace(anthro, **bounded)
        model = _model_lengths(anthro, trajectory)
        mults = {seg: bounded[seg] * lengths[seg] / model[seg] for seg in ratios}
    bounded = {k: float(np.clip(v, *MULTIPLIER_RANGE)) for k, v in mults.items()}
    clipped |= {k for k in mults if bounded[k] != mults[k]}
    return ScaleEstimate(replace(anthro, **bounded), lengths, counts, tuple(sorted(clipped)))
