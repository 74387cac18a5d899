"""Sensor-check sections of the depth camera: render-then-measure and depth noise.
"""

from __future__ import annotations

import numpy as np

from fusion.depth import Label
from scenarios.sensors.check.check_results import Section, around, relative
from sim.depth_camera import DepthCamera
from sim.depth_noise import DepthNoise, sigma_axial_mm
from sim.rig import CameraPlacement, look_at
from sim.scenes import Sphere, Wall, compile_scene

CAMERA = CameraPlacement("front", look_at([0.0, 0.0, 1.5], [1.0, 0.0, 1.5]))
"""Camera of the static scenes: 1.5 m above the floor, looking along world +x."""


_SPHERE_RADIUS_M = 0.1


_SPHERES = (  # name, (u, v) offset from the principal point in half image sizes, z [m] of the centre
    ("centre, 2 m", (0.0, 0.0), 2.0),
    ("top left, 2 m", (-0.8, -0.8), 2.0),
    ("top right, 2 m", (0.8, -0.8), 2.0),
    ("bottom left, 2 m", (-0.8, 0.8), 2.0),
    ("bottom right, 2 m", (0.8, 0.8), 2.0),
    ("near, 0.8 m", (-0.45, 0.3), 0.8),
    ("far, 4 m", (0.45, -0.3), 4.0),
)


_CENTROID_TOL_PX = 0.1


_NEAREST_TOL_MM = 1.0


_WALLS = ((1.0, 0.0), (2.5, 0.0), (4.0, 0.0), (2.5, 60.0), (2.5, 75.0))  # distance [m], tilt [deg]


_WALL_FRAMES = 3


_WINDOW_HALF_PX = (100, 10)  # rows, columns either side of the principal point: 201 x 21 px


NOISE_REL_TOL = 0.15


def check_projection(*, rng: np.random.Generator) -> Section:
    """Spheres at known places, rendered by an ideal camera: silhouette centroid and nearest depth.

    The centroid [px] of each sphere's BODY pixels is compared with the centre of its image ellipse
    (:meth:`sim.scenes.Sphere.image_centre`), the smallest depth [mm] with ``z_centre - radius``.
    """
    camera = DepthCamera(CAMERA, DepthNoise.none())
    intr = CAMERA.intrinsics
    composite = np.full((intr.height, intr.width), np.nan)
    expected_uv, measured_uv, offsets, checks = [], [], [], []
    for name, (du, dv), z in _SPHERES:
        uv_target = np.array([intr.cx + du * intr.width / 2, intr.cy + dv * intr.height / 2])
        p_cam = intr.backproject(uv_target, z)
        sphere = Sphere(CAMERA.T_world_cam[:3, :3] @ p_cam + CAMERA.position, _SPHERE_RADIUS_M)
        frame = camera.render(*compile_scene(sphere), rng=rng)
        v, u = np.nonzero(frame.labels == Label.BODY)
        centroid = np.array([u.mean(), v.mean()]) if u.size else np.full(2, np.nan)
        centre = sphere.image_centre(CAMERA)
        depth_mm = frame.depth_mm[v, u].astype(float)
        nearest = depth_mm.min() if depth_mm.size else np.nan
        composite[v, u] = np.fmin(composite[v, u], depth_mm)
        expected_uv.append(centre)
        measured_uv.append(centroid)
        offsets.append(np.linalg.norm(centre - uv_target))
        checks += [
            around(name, "silhouette centroid error", "px", np.linalg.norm(centroid - centre), 0.0, _CENTROID_TOL_PX,
                    f"<= {_CENTROID_TOL_PX} px", lowest=0.0, pixels=u.size,
                    **{"ellipse centre - projected centre [px]": offsets[-1]}),
            around(name, "nearest depth error", "mm", abs(nearest - 1e3 * z + 1e3 * _SPHERE_RADIUS_M), 0.0,
                    _NEAREST_TOL_MM, f"<= {_NEAREST_TOL_MM} mm", lowest=0.0, **{"nearest depth [mm]": nearest}),
        ]
    method = (
        f"Spheres of radius {_SPHERE_RADIUS_M} m, one at a time, seen by an ideal camera (`DepthNoise.none()`: no "
        "noise, only millimetre rounding) 1.5 m above the floor. Each sphere's centre is put on a known pixel (the "
        "principal point, 80 % of the way to a corner, or in between for the near and far ones) at a known depth. "
        "Expected: the centroid of its BODY pixels is the centre of the sphere's image, an ellipse computed in "
        "closed form from the intrinsics (off-axis it lies outward of the projected sphere centre, here by up to "
        f"{max(offsets):.1f} px, see notes); the tolerance covers sampling the silhouette at pixel centres. The "
        "smallest depth is the centre's z minus the radius; tolerance 0.5 mm rounding plus 0.5 mm for pixel centres "
        "missing the tangent point."
    )
    return Section("projection", method, tuple(checks),
                   {"depth_mm": composite, "expected_uv": np.array(expected_uv), "measured_uv": np.array(measured_uv)})


def check_depth_noise(*, rng: np.random.Generator, noise: DepthNoise = DepthNoise()) -> Section:
    """Walls at 1, 2.5, 4 m head-on and 2.5 m at 60 and 75 degrees: residual std vs sigma(z, theta)."""
    camera = DepthCamera(CAMERA, noise)
    intr = CAMERA.intrinsics
    (hr, hc), r0, c0 = _WINDOW_HALF_PX, round(intr.cy), round(intr.cx)
    window = (slice(r0 - hr, r0 + hr + 1), slice(c0 - hc, c0 + hc + 1))
    checks, rows = [], []
    for dist, tilt in _WALLS:
        wall = Wall([dist, 0.0, CAMERA.position[2]], tilt)
        model, data = compile_scene(wall)
        z, theta = (a[window] for a in wall.depth(CAMERA))
        frames = np.stack([camera.render(model, data, rng=rng).depth_mm[window] for _ in range(_WALL_FRAMES)])
        returned = frames > 0
        residual = frames[returned] - 1e3 * np.broadcast_to(z, frames.shape)[returned]
        sigma = sigma_axial_mm(z, theta, noise)
        expected = np.sqrt(np.mean(sigma**2) + 1 / 12)
        std = residual.std()
        checks.append(relative(
            f"wall {dist:g} m, {tilt:g} deg", "residual depth std", "mm", std, expected, NOISE_REL_TOL,
            **{"ratio": std / expected, "sigma(z, theta) RMS [mm]": np.sqrt(np.mean(sigma**2)),
               "mean residual [mm]": residual.mean(), "returned fraction": returned.mean()},
        ))
        rows.append((dist, tilt, np.degrees(theta.mean()), std, expected))
    method = (
        f"A flat wall (a 20 m box face) at {', '.join(f'{d:g} m / {t:g} deg' for d, t in _WALLS)} (distance along "
        f"the optical axis / incidence at the image centre), seen by the default noisy camera (lateral jitter and "
        f"flying pixels on). In a {2 * hr + 1} x {2 * hc + 1} px window at the image centre over {_WALL_FRAMES} "
        "frames, the residual is the measured depth minus the closed-form plane depth. Expected: Fankhauser's "
        "sigma(z, theta) (`sigma_axial_mm`, the values of sensors.md) per pixel, pooled as the root mean square "
        "over the window (theta varies across a tilted window). Quantisation: depths are rounded to whole "
        "millimetres, which adds an independent uniform error of variance 1/12 mm^2 (Sheppard's correction, "
        "accurate for sigma above about half the 1 mm step; here sigma >= 1.3 mm), so the expected std is "
        "sqrt(mean(sigma^2) + 1/12). Pass if the ratio measured / expected lies within 15 %."
    )
    return Section("depth_noise", method, tuple(checks), {"walls": np.array(rows)})
