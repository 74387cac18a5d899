"""The humanoid at run time: clinical coordinates to joint configurations, body poses and landmarks.

A :class:`Humanoid` wraps a MuJoCo model built by :func:`sim.humanoid_model.build_humanoid` (whose
docstring describes the joints, pivots, sites and geoms) and evaluates its forward kinematics,
vectorised over frames.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

import mujoco
import numpy as np

from fusion.errors import BadInputError, UnknownNameError
from fusion.topology import K4ABT, KINECT_V2, Topology
from sim.anthropometry import Anthropometry
from sim.coordinates import COORDINATES, INDEX, ROOT

SIDES = {"l": 1.0, "r": -1.0}  # side suffix -> sign of the lateral (y) direction


_TOPOLOGIES = {t.name: t for t in (KINECT_V2, K4ABT)}


class Humanoid:
    """A compiled humanoid and vectorised kinematics over coordinate arrays.

    Build it with :func:`build_humanoid`. Coordinate arrays have shape ``(T, K)`` with columns in
    the order of :data:`sim.coordinates.COORDINATES` (metres for ``root_x``/``root_y``, radians
    otherwise).

    Attributes
    ----------
    anthro : Anthropometry
        The subject's proportions.
    model : mujoco.MjModel
        The compiled model.
    data : mujoco.MjData
        Scratch data; :meth:`set_pose` writes into it.
    qpos_adr : Mapping[str, int]
        Coordinate name -> address in ``qpos``. Hinge coordinates map to their joint's single
        entry; ``root_x``/``root_y`` to the free joint's x/y; ``root_yaw`` to the start of the
        free joint's quaternion ``(w, x, y, z)``, which holds a rotation about world z.
    """

    def __init__(self, anthro: Anthropometry, model: mujoco.MjModel) -> None:
        """Wrap a model compiled by :func:`build_humanoid` (it relies on its joint and body names)."""
        self.anthro = anthro
        self.model = model
        self.data = mujoco.MjData(model)
        m = model
        root = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "root")
        self._root_adr = int(m.jnt_qposadr[root])
        hinge_names = [c for c in COORDINATES if c not in ROOT]
        hinge_adr = [int(m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, c)]) for c in hinge_names]
        self._hinge_cols = np.array([INDEX[c] for c in hinge_names], dtype=int)
        self._hinge_adr = np.array(hinge_adr, dtype=int)
        adr = dict(zip(hinge_names, hinge_adr))
        adr |= {"root_x": self._root_adr, "root_y": self._root_adr + 1, "root_yaw": self._root_adr + 3}
        self.qpos_adr: Mapping[str, int] = MappingProxyType({c: adr[c] for c in COORDINATES})

        self._body_R = np.empty((m.nbody, 3, 3))
        for b in range(m.nbody):
            mat = np.empty(9)
            mujoco.mju_quat2Mat(mat, m.body_quat[b])
            self._body_R[b] = mat.reshape(3, 3)
        self._joints = []  # per body: (type, qpos address, skew(axis), skew(axis)^2, anchor)
        for b in range(m.nbody):
            entries = []
            for j in range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b]):
                k = _skew(m.jnt_axis[j])
                entries.append((int(m.jnt_type[j]), int(m.jnt_qposadr[j]), k, k @ k, m.jnt_pos[j].copy()))
            self._joints.append(entries)

        self._thorax = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "thorax")
        feet = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, f"foot_{s}") for s in SIDES]
        self._foot_geoms = np.flatnonzero(np.isin(m.geom_bodyid, feet))
        self._foot_geom_R = _quat_to_mat(m.geom_quat[self._foot_geoms])
        self._body_geoms = np.flatnonzero(m.geom_bodyid != 0)
        self._floor = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "floor")
        self._sites = {
            name: np.array([mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, f"{name}/{j}") for j in topo.joints])
            for name, topo in _TOPOLOGIES.items()
        }

    @property
    def body_geom_ids(self) -> np.ndarray:
        """(G,) int ids of every geom attached to a body of the humanoid (not the floor)."""
        return self._body_geoms.copy()

    @property
    def floor_geom_id(self) -> int:
        """Id of the floor plane geom."""
        return self._floor

    def site_ids(self, topology: Topology) -> np.ndarray:
        """Site ids of a topology's joints.

        Parameters
        ----------
        topology : Topology
            :data:`~fusion.topology.KINECT_V2` or :data:`~fusion.topology.K4ABT`, or a reduction of one
            (UI-PRMD's: the sites of the joints that stand for it, :meth:`~fusion.topology.Topology.columns_in`).

        Returns
        -------
        numpy.ndarray
            (J,) int site ids in the topology's joint order.

        Raises
        ------
        UnknownNameError
            If the humanoid has no sites for this topology.
        """
        full = topology.full_set
        if _TOPOLOGIES.get(full.name) != full:
            raise UnknownNameError("humanoid topology", topology.name, _TOPOLOGIES)
        sites = self._sites[full.name]
        return sites[topology.columns_in(full)] if full is not topology else sites.copy()

    def qpos(self, coords: np.ndarray) -> np.ndarray:
        """MuJoCo generalised positions of a motion, grounded on the floor.

        Parameters
        ----------
        coords : numpy.ndarray
            (T, K) coordinates, metres / radians.

        Returns
        -------
        numpy.ndarray
            (T, nq) qpos; the root height puts the lowest point of the feet at z = 0 in each frame.

        Raises
        ------
        BadInputError
            If ``coords`` is not a finite (T, K) array.
        """
        return self._solve(_check_coords(coords, 2))[0]

    def set_pose(self, coords_row: np.ndarray) -> None:
        """Pose :attr:`data` (``qpos`` and ``mj_kinematics``) for one frame.

        Afterwards ``data.xpos``, ``data.geom_xpos``, ``data.geom_xmat`` and ``data.site_xpos`` are
        valid, e.g. for ``mujoco.mj_ray``.

        Parameters
        ----------
        coords_row : numpy.ndarray
            (K,) coordinates of one frame, metres / radians.

        Raises
        ------
        BadInputError
            If ``coords_row`` is not a finite (K,) array.
        """
        self.data.qpos[:] = self._solve(_check_coords(coords_row, 1)[None])[0][0]
        mujoco.mj_kinematics(self.model, self.data)

    def set_qpos(self, qpos_row: np.ndarray) -> None:
        """Pose :attr:`data` from a row of :meth:`qpos` (no re-grounding) and run ``mj_kinematics``.

        The fast path for loops over frames: compute ``qpos(coords)`` once, then call this per frame.

        Parameters
        ----------
        qpos_row : numpy.ndarray
            (nq,) generalised positions.
        """
        self.data.qpos[:] = qpos_row
        mujoco.mj_kinematics(self.model, self.data)

    def joint_positions(self, coords: np.ndarray, topology: Topology) -> np.ndarray:
        """True world positions of a topology's joints over a motion.

        Parameters
        ----------
        coords : numpy.ndarray
            (T, K) coordinates, metres / radians.
        topology : Topology
            :data:`~fusion.topology.KINECT_V2` or :data:`~fusion.topology.K4ABT`, or a reduction of one
            (UI-PRMD's: the sites of the joints that stand for it, :meth:`~fusion.topology.Topology.columns_in`).

        Returns
        -------
        numpy.ndarray
            (T, J, 3) site positions in the world frame, metres.

        Raises
        ------
        BadInputError
            If ``coords`` is not a finite (T, K) array.
        UnknownNameError
            If the humanoid has no sites for this topology.
        """
        _, R, p = self._solve(_check_coords(coords, 2))
        return self._sites_from(R, p, topology)

    def facing_yaw(self, coords: np.ndarray) -> np.ndarray:
        """Heading of the thorax in the world xy plane.

        The heading is the direction 90 degrees clockwise (seen from above) of the thorax's
        left-pointing axis, i.e. the chest's forward direction, robust to trunk flexion.

        Parameters
        ----------
        coords : numpy.ndarray
            (T, K) coordinates, metres / radians.

        Returns
        -------
        numpy.ndarray
            (T,) yaw in radians in [-pi, pi]; 0 faces world +x, pi/2 faces world +y.

        Raises
        ------
        BadInputError
            If ``coords`` is not a finite (T, K) array.
        """
        _, R, _ = self._solve(_check_coords(coords, 2))
        return self._facing_from(R)

    def track(self, coords: np.ndarray, topology: Topology) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`qpos`, :meth:`joint_positions` and :meth:`facing_yaw` from one kinematics pass.

        Returns
        -------
        qpos : (T, nq); joints : (T, J, 3) world [m]; facing : (T,) [rad].
        """
        qpos, R, p = self._solve(_check_coords(coords, 2))
        return qpos, self._sites_from(R, p, topology), self._facing_from(R)

    def _sites_from(self, R: np.ndarray, p: np.ndarray, topology: Topology) -> np.ndarray:
        sites = self.site_ids(topology)
        body = self.model.site_bodyid[sites]
        return p[:, body] + np.einsum("tjab,jb->tja", R[:, body], self.model.site_pos[sites])

    def _facing_from(self, R: np.ndarray) -> np.ndarray:
        left = R[:, self._thorax, :, 1]
        return np.arctan2(-left[:, 0], left[:, 1])

    def _solve(self, coords: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Grounded qpos (T, nq), body rotations (T, nbody, 3, 3) and positions (T, nbody, 3)."""
        n = len(coords)
        qpos = np.tile(self.model.qpos0, (n, 1))
        a = self._root_adr
        yaw = coords[:, INDEX["root_yaw"]]
        qpos[:, a] = coords[:, INDEX["root_x"]]
        qpos[:, a + 1] = coords[:, INDEX["root_y"]]
        qpos[:, a + 2] = 0.0
        qpos[:, a + 3 : a + 7] = 0.0
        qpos[:, a + 3] = np.cos(yaw / 2)
        qpos[:, a + 6] = np.sin(yaw / 2)
        qpos[:, self._hinge_adr] = coords[:, self._hinge_cols]
        R, p = self._forward(qpos)
        lift = -self._lowest_foot_z(R, p)
        qpos[:, a + 2] = lift
        p[:, 1:, 2] += lift[:, None]
        return qpos, R, p

    def _forward(self, qpos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Body rotations (T, nbody, 3, 3) and positions (T, nbody, 3) for (T, nq) qpos, as mj_kinematics."""
        m, n = self.model, len(qpos)
        R = np.empty((n, m.nbody, 3, 3))
        p = np.empty((n, m.nbody, 3))
        R[:, 0], p[:, 0] = np.eye(3), 0.0
        for b in range(1, m.nbody):
            parent = m.body_parentid[b]
            Rb = R[:, parent] @ self._body_R[b]
            pb = p[:, parent] + R[:, parent] @ m.body_pos[b]
            for jtype, adr, k, k2, anchor in self._joints[b]:
                if jtype == mujoco.mjtJoint.mjJNT_FREE:
                    pb = qpos[:, adr : adr + 3].copy()
                    Rb = _quat_to_mat(qpos[:, adr + 3 : adr + 7])
                else:  # hinge about the anchor, as mj_kinematics does
                    q = qpos[:, adr, None, None]
                    x_anchor = pb + Rb @ anchor
                    Rb = Rb @ (np.eye(3) + np.sin(q) * k + (1.0 - np.cos(q)) * k2)
                    pb = x_anchor - Rb @ anchor
            R[:, b], p[:, b] = Rb, pb
        return R, p

    def _lowest_foot_z(self, R: np.ndarray, p: np.ndarray) -> np.ndarray:
        """(T,) lowest z of the foot boxes, metres."""
        m = self.model
        g = self._foot_geoms
        body = m.geom_bodyid[g]
        centre_z = p[:, body, 2] + np.einsum("tgb,gb->tg", R[:, body, 2], m.geom_pos[g])
        world_row_z = np.einsum("tgb,gbc->tgc", R[:, body, 2], self._foot_geom_R)  # z-row of each box's rotation
        reach = np.einsum("tgc,gc->tg", np.abs(world_row_z), m.geom_size[g])
        return (centre_z - reach).min(axis=1)


def _check_coords(coords: np.ndarray, ndim: int) -> np.ndarray:
    """Validate (T, K) (``ndim`` 2) or (K,) (``ndim`` 1) coordinates; float64 copy."""
    k = len(COORDINATES)
    want = f"(T, {k})" if ndim == 2 else f"({k},)"
    try:
        arr = np.array(coords, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise BadInputError(f"coordinates must be a numeric array of shape {want}: {err}") from None
    if arr.ndim != ndim or arr.shape[-1] != k:
        raise BadInputError(
            f"coordinates must have shape {want} with columns sim.coordinates.COORDINATES, got {arr.shape}"
        )
    bad = ~np.isfinite(arr)
    if bad.any():
        where = np.argwhere(bad.reshape(-1, k))[0]
        raise BadInputError(
            f"coordinates contain NaN or inf ({int(bad.sum())} values), first at frame {where[0]}, "
            f"coordinate {COORDINATES[where[1]]!r}"
        )
    return arr


def _skew(v: np.ndarray) -> np.ndarray:
    """(3, 3) cross-product matrix of a (3,) vector."""
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def _quat_to_mat(q: np.ndarray) -> np.ndarray:
    """(N, 3, 3) rotation matrices of (N, 4) quaternions (w, x, y, z), normalised first."""
    w, x, y, z = (q / np.linalg.norm(q, axis=1, keepdims=True)).T
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1),
        ],
        axis=-2,
    )
