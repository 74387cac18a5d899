"""Compiled first hits of rays on MuJoCo's primitive geoms: spheres, capsules, ellipsoids, cylinders, boxes.

The same answer as ``mujoco.mj_multiRay`` (distance, geom id, outward normal of the first surface each
ray meets) for scenes whose candidate geoms are all primitives, two to three times faster on the
humanoid's 22 body geoms: each run of consecutive rays first drops the geoms outside the cone around
them, each ray then tests the rest's bounding spheres and skips geoms that cannot beat its nearest
hit so far, and only the survivors get their exact test. :func:`sim.raycast.cast_rays` chooses this
path when it applies; MuJoCo's remains the reference (``tests/sim/test_primitive_rays.py``).

Surfaces follow MuJoCo's geom conventions (geom frame, ``geom_size``): a capsule or cylinder of
radius ``size[0]`` and half-length ``size[1]`` along the geom's z axis, an ellipsoid of semi-axes
``size``, a box of half-sizes ``size``. A ray starting inside a geom hits it from the inside.
"""

from __future__ import annotations

import math

import mujoco
import numba
import numpy as np

PRIMITIVE_TYPES = (
    int(mujoco.mjtGeom.mjGEOM_SPHERE),
    int(mujoco.mjtGeom.mjGEOM_CAPSULE),
    int(mujoco.mjtGeom.mjGEOM_ELLIPSOID),
    int(mujoco.mjtGeom.mjGEOM_CYLINDER),
    int(mujoco.mjtGeom.mjGEOM_BOX),
)
_SPHERE, _CAPSULE, _ELLIPSOID, _CYLINDER, _BOX = PRIMITIVE_TYPES
_CHUNK = 32  # consecutive rays that share one cull of the geoms by the cone around them


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _sphere(px, py, pz, dx, dy, dz, r):
    """Smallest t >= 0 where the ray p + t d meets the sphere of radius r about the origin; inf if none."""
    b = px * dx + py * dy + pz * dz
    c = px * px + py * py + pz * pz - r * r
    disc = b * b - c
    if disc < 0.0:
        return math.inf
    s = math.sqrt(disc)
    t = -b - s
    if t < 0.0:
        t = -b + s
    return t if t >= 0.0 else math.inf


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _cap(px, py, pz, dx, dy, dz, r, end):
    """Smallest t >= 0 on the half of the sphere of radius r about (0, 0, end) beyond z = end; inf if none."""
    qz = pz - end
    b = px * dx + py * dy + qz * dz
    disc = b * b - (px * px + py * py + qz * qz - r * r)
    if disc < 0.0:
        return math.inf
    s = math.sqrt(disc)
    for t in (-b - s, -b + s):
        if t >= 0.0 and (qz + t * dz) * end >= 0.0:
            return t
    return math.inf


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _tube(px, py, pz, dx, dy, dz, r, h):
    """The side of the cylinder x^2 + y^2 = r^2, |z| <= h: (smallest t >= 0 on it or inf, whether the ray
    can reach the solid at all, whether it enters the infinite cylinder on this side)."""
    a = dx * dx + dy * dy
    b = px * dx + py * dy
    c = px * px + py * py - r * r
    if a < 1e-15:  # parallel to the axis: only the ends, if within the radius
        return math.inf, c <= 0.0, False
    disc = b * b - a * c
    if disc < 0.0:
        return math.inf, False, False
    s = math.sqrt(disc)
    t = (-b - s) / a
    if t >= 0.0 and abs(pz + t * dz) <= h:
        return t, True, True
    t = (-b + s) / a
    if t >= 0.0 and abs(pz + t * dz) <= h:
        return t, True, False
    return math.inf, t >= 0.0, False


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _set(normal, x, y, z):
    n = math.sqrt(x * x + y * y + z * z)
    normal[0], normal[1], normal[2] = x / n, y / n, z / n


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _round(kind, px, py, pz, dx, dy, dz, s0, s1, normal):
    """Sphere, capsule or cylinder: first hit t >= 0 (inf if none), local outward normal into ``normal``."""
    if kind == _SPHERE:
        t, cz = _sphere(px, py, pz, dx, dy, dz, s0), 0.0
    else:
        t, reach, entry = _tube(px, py, pz, dx, dy, dz, s0, s1)
        cz = 0.0  # on the side the normal is radial
        if not reach:
            return math.inf
        for end in (s1, -s1):
            if entry:  # nothing of the solid lies before where the ray enters its infinite cylinder
                break
            if kind == _CAPSULE:
                te = _cap(px, py, pz, dx, dy, dz, s0, end)
            elif abs(dz) > 1e-15:
                te = (end - pz) / dz
                if te < 0.0 or (px + te * dx) ** 2 + (py + te * dy) ** 2 > s0 * s0:
                    te = math.inf
            else:
                te = math.inf
            if te < t:
                t, cz = te, end
    if t == math.inf:
        return t
    hx, hy, hz = px + t * dx, py + t * dy, pz + t * dz
    if kind == _SPHERE or (kind == _CAPSULE and cz != 0.0):
        _set(normal, hx, hy, hz - cz)
    elif cz != 0.0:  # a cylinder's flat cap
        _set(normal, 0.0, 0.0, cz)
    else:
        _set(normal, hx, hy, 0.0)
    return t


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _ellipsoid(px, py, pz, dx, dy, dz, s0, s1, s2, normal):
    """First hit t >= 0 on the ellipsoid of semi-axes s (inf if none), local outward normal into ``normal``."""
    qx, qy, qz, ex, ey, ez = px / s0, py / s1, pz / s2, dx / s0, dy / s1, dz / s2
    a = ex * ex + ey * ey + ez * ez
    b = qx * ex + qy * ey + qz * ez
    disc = b * b - a * (qx * qx + qy * qy + qz * qz - 1.0)
    if disc < 0.0:
        return math.inf
    t = (-b - math.sqrt(disc)) / a
    if t < 0.0:
        t = (-b + math.sqrt(disc)) / a
    if t < 0.0:
        return math.inf
    _set(normal, (px + t * dx) / (s0 * s0), (py + t * dy) / (s1 * s1), (pz + t * dz) / (s2 * s2))
    return t


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _box(p, d, half, normal):
    """First hit t >= 0 on the box of half-sizes ``half`` (slabs; inf if none), local outward normal into ``normal``."""
    near, far, near_axis, far_axis = -math.inf, math.inf, 0, 0
    for i in range(3):
        if abs(d[i]) < 1e-15:
            if abs(p[i]) > half[i]:
                return math.inf
            continue
        t1, t2 = (-half[i] - p[i]) / d[i], (half[i] - p[i]) / d[i]
        if t1 > t2:
            t1, t2 = t2, t1
        if t1 > near:
            near, near_axis = t1, i
        if t2 < far:
            far, far_axis = t2, i
    if near > far or far < 0.0:
        return math.inf
    normal[:] = 0.0
    if near >= 0.0:  # entering across ``near_axis``
        normal[near_axis] = -math.copysign(1.0, d[near_axis])
        return near
    normal[far_axis] = math.copysign(1.0, d[far_axis])  # from the inside: leaving across ``far_axis``
    return far


@numba.njit(cache=True, nogil=True, error_model="numpy")
def prepare(origin, pos, mat, rbound):
    """Per-geom constants of rays from ``origin`` (3,) [m] at geoms at ``pos`` (G, 3), ``mat`` (G, 9).

    Returns the centres seen from the origin (G, 3) [m], the origin in each geom's frame (G, 3) [m] and
    ``|centre|^2 - rbound^2`` (G,) [m^2]: a ray whose projection ``a`` on a centre has ``a^2`` below it
    misses that geom's bounding sphere.
    """
    n_geoms = pos.shape[0]
    centre = pos - origin
    start = np.empty((n_geoms, 3))
    out_sq = np.empty(n_geoms)
    for g in range(n_geoms):
        for i in range(3):
            start[g, i] = -(mat[g, i] * centre[g, 0] + mat[g, 3 + i] * centre[g, 1] + mat[g, 6 + i] * centre[g, 2])
        out_sq[g] = centre[g, 0] ** 2 + centre[g, 1] ** 2 + centre[g, 2] ** 2 - rbound[g] ** 2
    return centre, start, out_sq


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _cone_geoms(dirs, lo, hi, centre, rbound, out):
    """Geoms whose bounding sphere a cone around rays ``dirs[lo:hi]`` reaches: their count, indices in ``out``.

    The cone's axis is the rays' normalised sum and its half-angle the widest ray's; a geom is kept
    unless its bounding sphere lies wholly outside that cone (conservative: never drops a hit).
    """
    ax = ay = az = 0.0
    for k in range(lo, hi):
        ax += dirs[k, 0]
        ay += dirs[k, 1]
        az += dirs[k, 2]
    norm = math.sqrt(ax * ax + ay * ay + az * az)
    count = 0
    if norm < 1e-9 * (hi - lo):  # rays in opposite directions: no cone to cull by
        for g in range(centre.shape[0]):
            out[g] = g
        return centre.shape[0]
    ax, ay, az = ax / norm, ay / norm, az / norm
    cos_cone = 1.0
    for k in range(lo, hi):
        cos_cone = min(cos_cone, ax * dirs[k, 0] + ay * dirs[k, 1] + az * dirs[k, 2])
    sin_cone = math.sqrt(max(0.0, 1.0 - cos_cone * cos_cone))
    for g in range(centre.shape[0]):
        dist = math.sqrt(centre[g, 0] ** 2 + centre[g, 1] ** 2 + centre[g, 2] ** 2)
        if dist > rbound[g]:
            sin_g = rbound[g] / dist
            cos_g = math.sqrt(1.0 - sin_g * sin_g)
            cos_axis = (ax * centre[g, 0] + ay * centre[g, 1] + az * centre[g, 2]) / dist
            # outside: the angle to the axis exceeds the cone's and the sphere's half-angles, summed below pi
            if cos_cone > -cos_g and cos_axis < cos_cone * cos_g - sin_cone * sin_g:
                continue
        out[count] = g
        count += 1
    return count


@numba.njit(cache=True, nogil=True, error_model="numpy")
def first_hits(origin, dirs, kinds, pos, mat, size, rbound, cutoff, geom_out, dist_out, normal_out):
    """Cast rays ``dirs`` (N, 3) unit, world, from ``origin`` (3,) [m] at G primitive geoms.

    ``kinds`` (G,) MuJoCo geom types (:data:`PRIMITIVE_TYPES`), ``pos`` (G, 3) and ``mat`` (G, 9) their
    world poses, ``size`` (G, 3) ``geom_size``, ``rbound`` (G,) bounding radii [m]. Hits beyond
    ``cutoff`` [m] are ignored. Writes per ray the index into the G geoms (-1 none), the distance
    (inf none) and the world outward normal (NaN none) into ``geom_out``, ``dist_out``, ``normal_out``.
    """
    centre, start, out_sq = prepare(origin, pos, mat, rbound)
    local_n, lp, ld = np.empty(3), np.empty(3), np.empty(3)
    near = np.empty(kinds.shape[0], dtype=np.intp)
    n_near = 0
    for k in range(dirs.shape[0]):
        if k % _CHUNK == 0:
            n_near = _cone_geoms(dirs, k, min(k + _CHUNK, dirs.shape[0]), centre, rbound, near)
        dx, dy, dz = dirs[k, 0], dirs[k, 1], dirs[k, 2]
        best, best_g = cutoff, -1
        nx = ny = nz = math.nan
        for j in range(n_near):
            g = near[j]
            along = centre[g, 0] * dx + centre[g, 1] * dy + centre[g, 2] * dz
            if along + rbound[g] < 0.0 or along - rbound[g] > best or along * along < out_sq[g]:
                continue
            m = mat[g]
            px, py, pz = start[g, 0], start[g, 1], start[g, 2]
            lx = m[0] * dx + m[3] * dy + m[6] * dz  # the direction in the geom's frame: R^T d
            ly = m[1] * dx + m[4] * dy + m[7] * dz
            lz = m[2] * dx + m[5] * dy + m[8] * dz
            kind = kinds[g]
            if kind == _ELLIPSOID:
                t = _ellipsoid(px, py, pz, lx, ly, lz, size[g, 0], size[g, 1], size[g, 2], local_n)
            elif kind == _BOX:
                lp[0], lp[1], lp[2], ld[0], ld[1], ld[2] = px, py, pz, lx, ly, lz
                t = _box(lp, ld, size[g], local_n)
            else:
                t = _round(kind, px, py, pz, lx, ly, lz, size[g, 0], size[g, 1], local_n)
            if t < best:
                best, best_g = t, g
                nx = m[0] * local_n[0] + m[1] * local_n[1] + m[2] * local_n[2]
                ny = m[3] * local_n[0] + m[4] * local_n[1] + m[5] * local_n[2]
                nz = m[6] * local_n[0] + m[7] * local_n[1] + m[8] * local_n[2]
        geom_out[k] = best_g
        dist_out[k] = best if best_g >= 0 else math.inf
        normal_out[k, 0], normal_out[k, 1], normal_out[k, 2] = nx, ny, nz
