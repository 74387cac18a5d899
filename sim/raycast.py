"""Ray casting against a MuJoCo scene: the one entry point every sensor model uses.

Casts many rays from one point with input checks and returns a result object in metres, with
``inf`` / ``-1`` / NaN where a ray hits nothing. The rays see what ``mujoco.mj_multiRay`` sees: the
visible geoms (alpha > 0) of the chosen geom groups. Where all of those are primitives (spheres,
capsules, ellipsoids, cylinders, boxes, as the humanoid's body) the compiled caster of
:mod:`sim.primitive_rays` answers, two to three times faster on the humanoid; otherwise ``mj_multiRay``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from fusion.errors import BadInputError
from sim.primitive_rays import PRIMITIVE_TYPES, first_hits

_UNIT_TOL = 1e-6


@dataclass(frozen=True, eq=False)
class RayHits:
    """First hits of N rays.

    Attributes
    ----------
    dist : np.ndarray
        (N,) float64 distance along each ray to the first hit [m]; ``inf`` where the ray hits nothing.
    geom_id : np.ndarray
        (N,) int32 MuJoCo geom id of the hit; -1 where nothing is hit.
    normal_world : np.ndarray
        (N, 3) float64 unit outward surface normal at the hit, world frame; NaN where nothing is hit.
    """

    dist: np.ndarray
    geom_id: np.ndarray
    normal_world: np.ndarray

    def __post_init__(self) -> None:
        dist = np.ascontiguousarray(self.dist, dtype=np.float64)
        gid = np.ascontiguousarray(self.geom_id, dtype=np.int32)
        normal = np.ascontiguousarray(self.normal_world, dtype=np.float64)
        if dist.ndim != 1 or gid.shape != dist.shape or normal.shape != dist.shape + (3,):
            raise BadInputError(
                "RayHits needs dist (N,), geom_id (N,), normal_world (N, 3); "
                f"got {dist.shape}, {gid.shape}, {normal.shape}"
            )
        if np.any((gid < 0) != np.isinf(dist)):
            raise BadInputError("RayHits: dist must be inf exactly where geom_id is -1")
        for name, arr in (("dist", dist), ("geom_id", gid), ("normal_world", normal)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @property
    def hit(self) -> np.ndarray:
        """(N,) bool, True where the ray hits a geom."""
        return self.geom_id >= 0


def _check_group(geomgroup: Sequence[bool | int]) -> np.ndarray:
    group = np.asarray(geomgroup)
    if group.shape != (6,) or not np.all((group == 0) | (group == 1)):
        raise BadInputError(f"geomgroup must be 6 booleans (one per MuJoCo geom group) or None, got {geomgroup!r}")
    return group.astype(np.uint8)


def _check_rays(
    model: mujoco.MjModel, data: mujoco.MjData, origin: np.ndarray, dirs: np.ndarray, cutoff_m: float
) -> None:
    """Raise BadInputError unless :func:`cast_rays` can cast ``dirs`` (N, 3) from ``origin`` (3,) in ``data``."""
    if origin.shape != (3,) or not np.all(np.isfinite(origin)):
        raise BadInputError(f"origin_world must be a finite (3,) point, got shape {origin.shape}")
    if dirs.ndim != 2 or dirs.shape[1] != 3:
        raise BadInputError(f"dirs_world must have shape (N, 3), got {dirs.shape}")
    if not np.all(np.isfinite(dirs)) or np.any(np.abs(np.einsum("ij,ij->i", dirs, dirs) - 1.0) > _UNIT_TOL):
        raise BadInputError("dirs_world must be finite unit vectors; normalise them first")
    if not (cutoff_m > 0):
        raise BadInputError(f"cutoff_m must be positive, got {cutoff_m}")
    if data.geom_xpos.shape[0] != model.ngeom or data.qpos.shape[0] != model.nq:
        raise BadInputError("data does not belong to model (geom or coordinate counts differ)")


def cast_rays(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    origin_world: np.ndarray,
    dirs_world: np.ndarray,
    *,
    geomgroup: Sequence[bool | int] | None,
    cutoff_m: float,
    check: bool = True,
) -> RayHits:
    """Cast rays from one point and return the first geom each ray hits.

    Parameters
    ----------
    model, data : the MuJoCo scene; ``data`` must hold current kinematics (``mj_kinematics``).
    origin_world : (3,) ray origin, world frame [m].
    dirs_world : (N, 3) unit ray directions, world frame.
    geomgroup : 6 flags, one per MuJoCo geom group, saying which groups the rays can hit;
        None for all groups.
    cutoff_m : hits further than this [m] are ignored (``inf`` allowed).
    check : validate the inputs; False skips it, for hot loops whose rays are unit by construction.

    Returns
    -------
    RayHits
        Distances [m] (ray length, not z-depth), geom ids and world normals.

    Raises
    ------
    BadInputError
        Wrong shapes, non-finite or non-unit inputs, a bad ``geomgroup`` or cutoff, or ``data``
        not belonging to ``model``.
    """
    origin = np.ascontiguousarray(origin_world, dtype=np.float64)
    dirs = np.ascontiguousarray(dirs_world, dtype=np.float64)
    if check:
        _check_rays(model, data, origin, dirs, cutoff_m)
    group = None if geomgroup is None else _check_group(geomgroup)

    n = dirs.shape[0]
    if n == 0:
        return RayHits(np.full(0, np.inf), np.full(0, -1, dtype=np.int32), np.full((0, 3), np.nan))
    geoms = primitive_geoms(model, group)
    if geoms is not None:
        return RayHits(*_cast_primitives(model, data, geoms, origin, dirs, cutoff_m))
    geom_id = np.full(n, -1, dtype=np.int32)
    dist = np.full(n, np.inf)
    normal = np.full((n, 3), np.nan)
    mj_dist = np.empty(n)
    mj_normal = np.empty(3 * n)
    cutoff = min(float(cutoff_m), mujoco.mjMAXVAL)
    mujoco.mj_multiRay(model, data, origin, dirs.ravel(), group, 1, -1, geom_id, mj_dist, mj_normal, n, cutoff)
    hit = (geom_id >= 0) & (mj_dist <= cutoff_m)
    geom_id[~hit] = -1
    dist[hit] = mj_dist[hit]
    normal[hit] = mj_normal.reshape(n, 3)[hit]
    return RayHits(dist, geom_id, normal)


def primitive_geoms(model: mujoco.MjModel, group: np.ndarray | None) -> np.ndarray | None:
    """Ids of the geoms rays of geom groups ``group`` (6 flags, None for all) can hit, if all are primitives.

    Those are the visible geoms (alpha > 0) of the groups, MuJoCo's group of a geom clamped to 0-5 as
    ``mj_ray`` does; None where one of them is not a :data:`sim.primitive_rays.PRIMITIVE_TYPES` geom.
    """
    seen = model.geom_rgba[:, 3] != 0
    if group is not None:
        seen &= group[np.clip(model.geom_group, 0, len(group) - 1)].astype(bool)
    geoms = np.flatnonzero(seen)
    return geoms if np.all(np.isin(model.geom_type[geoms], PRIMITIVE_TYPES)) else None


def _cast_primitives(
    model: mujoco.MjModel, data: mujoco.MjData, geoms: np.ndarray, origin: np.ndarray, dirs: np.ndarray,
    cutoff_m: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`sim.primitive_rays.first_hits` of ``dirs`` (N, 3) at ``geoms``: distances, model geom ids, normals."""
    n = dirs.shape[0]
    index, dist, normal = np.empty(n, dtype=np.intp), np.empty(n), np.empty((n, 3))
    first_hits(origin, dirs, model.geom_type[geoms], data.geom_xpos[geoms], data.geom_xmat[geoms],
               model.geom_size[geoms], model.geom_rbound[geoms], float(cutoff_m), index, dist, normal)
    geom_id = np.full(n, -1, dtype=np.int32)
    hit = index >= 0
    geom_id[hit] = geoms[index[hit]]
    return dist, geom_id, normal


class RayBatchCaster:
    """Repeated casts of ``n_rays`` rays against one model, for hot loops over frames.

    Arguments are validated once at construction; :meth:`cast` then only casts (compiled primitives
    or ``mujoco.mj_multiRay``, as :func:`cast_rays` chooses). Use :func:`cast_rays` for one-off casts.

    Parameters
    ----------
    model : the MuJoCo model.
    n_rays : number of rays per cast.
    geomgroup : 6 flags, one per geom group, saying which groups the rays can hit; None for all.
    """

    def __init__(self, model: mujoco.MjModel, n_rays: int, *, geomgroup: Sequence[bool | int] | None) -> None:
        if n_rays < 1:
            raise BadInputError(f"n_rays must be >= 1, got {n_rays}")
        self.model = model
        self.n_rays = int(n_rays)
        self._group = None if geomgroup is None else _check_group(geomgroup)
        self._primitives = primitive_geoms(model, self._group)
        self._geom = np.empty(n_rays, dtype=np.int32)
        self._dist = np.empty(n_rays)

    def cast(
        self, data: mujoco.MjData, origin_world: np.ndarray, dirs_world: np.ndarray, cutoff_m: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """First hits: geom ids (n_rays,) int32 (-1 none) and ray lengths (n_rays,) [m] (inf none).

        ``origin_world`` must be a float64 (3,) point and ``dirs_world`` a C-contiguous float64
        (n_rays, 3) array of unit vectors; the returned arrays are fresh copies.
        """
        if self._primitives is not None:
            dist, geom, _ = _cast_primitives(self.model, data, self._primitives, origin_world, dirs_world, cutoff_m)
            return geom, dist
        mujoco.mj_multiRay(self.model, data, origin_world, dirs_world.ravel(), self._group, 1, -1,
                           self._geom, self._dist, None, self.n_rays, min(float(cutoff_m), mujoco.mjMAXVAL))
        miss = (self._geom < 0) | (self._dist > cutoff_m)
        return np.where(miss, -1, self._geom), np.where(miss, np.inf, self._dist)
