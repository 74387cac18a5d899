"""What a calibration from the body returns: per-pair results and the whole rig with its diagnostics."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from fusion.calibrate.consistency import EdgeCheck
from fusion.calibrate.edges import PairEdge
from fusion.calibrate.floor import FloorPlane
from fusion.calibrate.icp_result import IcpResult
from fusion.calibrate.loop import LoopClosure
from fusion.calibrate.options import Refinement, RigMethod
from fusion.calibrate.ransac_result import PairCalibration
from fusion.calibrate.rig_graph import RigSolution
from fusion.calibration import WORLD, Calibration
from fusion.camera import Intrinsics
from fusion.transforms import compose, invert


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

    @property
    def skeleton_uncertainty(self) -> tuple[float, float]:
        """(rotation [deg], translation [mm]) standard deviation of the skeleton transform: the bootstrap
        spread and the systematic part in quadrature."""
        return (float(np.hypot(self.rotation_std_deg, self.skeleton_std[0])),
                float(np.hypot(self.translation_std_mm, self.skeleton_std[1])))

    def edge(self, *, refined: bool = True) -> PairEdge:
        """The pose-graph edge of this pair: the final (or the skeleton) transform with its uncertainty."""
        if refined and self.refined:
            return PairEdge.from_std(self.T_a_b, self.icp_std[0], self.icp_std[1] * 1e-3)
        rotation_deg, translation_mm = self.skeleton_uncertainty
        return PairEdge.from_std(self.T_a_b_skeleton, rotation_deg, translation_mm * 1e-3)


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
    edge_checks : cycle-consistency check of every edge the rig solver used.
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
    edge_checks: tuple[EdgeCheck, ...] = ()
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def distrusted(self) -> tuple[tuple[str, str], ...]:
        """Edges the rig solver down-weighted for disagreeing with the rest of the rig."""
        return tuple(c.key for c in self.edge_checks if c.distrusted)

    @property
    def camera_names(self) -> tuple[str, ...]:
        """Calibrated cameras."""
        return tuple(self.T_world_cam)


def relative_poses(T_world_cam: dict[str, np.ndarray], reference: str) -> dict[str, np.ndarray]:
    """``T_ref_cam`` of every camera from world poses."""
    T_ref_world = invert(T_world_cam[reference])
    return {n: compose(T_ref_world, T) for n, T in T_world_cam.items()}


def _pair_entry(p) -> dict[str, Any]:
    entry: dict[str, Any] = {
        "cameras": [p.a, p.b],
        "support": round(float(p.ransac.support), 4),
        "residual_rmse_mm": round(float(p.ransac.rmse) * 1e3, 2),
        "rotation_std_deg": round(p.rotation_std_deg, 4),
        "translation_std_mm": round(p.translation_std_mm, 2),
        "icp": "not run" if p.icp is None else ("accepted" if p.icp.accepted else "rejected"),
    }
    if p.icp is not None:
        entry |= {"icp_fitness": round(float(p.icp.fitness), 4), "icp_rmse_mm": round(float(p.icp.inlier_rmse_m) * 1e3, 2)}
    if p.icp_note:
        entry["note"] = p.icp_note
    return entry


def calibration_from_rig(rig: RigCalibration) -> Calibration:
    """The storable part of a :class:`~fusion.calibrate.results.RigCalibration`."""
    refine, notes = rig.refine.value, list(rig.notes)
    if refine != "none" and not any(p.icp is not None and p.icp.accepted for p in rig.pairs):
        refine = "none"  # what the poses are: say so, not what was asked for
        notes.append(f"refine = {rig.refine.value!r} was asked for, but no pair was refined (no usable depth "
                     "frames, or every refinement rejected): the poses are the skeleton calibration's")
    info: dict[str, Any] = {"refine": refine, "rig": rig.rig.value, "world": WORLD,
                            "notes": notes, "pair": [_pair_entry(p) for p in rig.pairs]}
    if rig.floor is not None:
        info["floor_rmse_mm"] = round(rig.floor.rmse_m * 1e3, 3)
    if rig.loop is not None:
        info["loop_closure_mm"] = round(rig.loop.mean_mm, 3)
    if rig.distrusted:
        info["distrusted"] = [list(key) for key in rig.distrusted]
    return Calibration(dict(rig.T_world_cam), dict(rig.intrinsics), dict(rig.clock_offset_s), rig.reference, info)
