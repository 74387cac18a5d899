"""Site Jacobians from the joints' axes: equal to MuJoCo's own, for every degree of freedom of the humanoid."""

from __future__ import annotations

import mujoco
import numpy as np

from fusion.topology import K4ABT
from sim.anthropometry import Anthropometry
from sim.humanoid_model import build_humanoid
from sim.site_jacobian import SiteJacobian


def test_equals_mj_jac_site_at_random_poses():
    humanoid = build_humanoid(Anthropometry(height_m=1.74))
    m = humanoid.model
    d = mujoco.MjData(m)
    sites = humanoid.site_ids(K4ABT)
    jacobian = SiteJacobian(m, sites, np.arange(m.nv))
    rows = np.arange(0, len(sites), 2)
    rng = np.random.default_rng(5)
    expected = np.zeros((3, m.nv))
    quat = int(m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "root")]) + 3
    for _ in range(4):
        d.qpos[:] = m.qpos0 + rng.normal(0, 0.4, m.nq)
        d.qpos[quat : quat + 4] = rng.normal(size=4)  # the free joint turned about all three axes
        d.qpos[quat : quat + 4] /= np.linalg.norm(d.qpos[quat : quat + 4])
        mujoco.mj_kinematics(m, d)
        got = jacobian(d, rows)
        mujoco.mj_comPos(m, d)
        for i, site in enumerate(sites[rows]):
            mujoco.mj_jacSite(m, d, expected, None, int(site))
            np.testing.assert_allclose(got[i], expected, atol=1e-12)
