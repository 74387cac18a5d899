"""Report pictures: the shared matplotlib set-up (headless, atomic PNG writes), and the pictures of a
run: a top view of rig and subject, and per camera a depth image with the projected skeleton coloured
by tracking state (a simulated run is drawn from its ground truth, a real recording from its
calibration); and of a fusion with limb axes, ``limb_axes.png``: one depth instant's limb points with
their fitted axes, the tracker's joints and the corrected ones, seen along the world's x and y axes,
and per segment at which instants of the session a fit counted."""

from __future__ import annotations

import io
import os
from collections.abc import Mapping
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from fusion.calibration import Calibration  # noqa: E402
from fusion.errors import BadInputError  # noqa: E402
from fusion.io.atomic import write_bytes_atomic  # noqa: E402
from fusion.merge.cloud import OutlierRemoval, merge_clouds  # noqa: E402
from fusion.merge.kinematic import measurement_targets  # noqa: E402
from fusion.merge.limb_axes import segment_points  # noqa: E402
from fusion.merge.limb_axis_options import LimbAxisOptions  # noqa: E402
from fusion.merge.limb_corrections import LimbAxes  # noqa: E402
from fusion.merge.views import CameraViews  # noqa: E402
from fusion.recording import CameraRecording, Recording  # noqa: E402
from fusion.topology import Landmark, TrackingState  # noqa: E402
from fusion.transforms import apply  # noqa: E402
from sim.truth import GroundTruth  # noqa: E402

STATE_COLOURS = {0: "#9e9e9e", 1: "#ffb300", 2: "#2e7d32", 3: "#1565c0"}
"""Colour per TrackingState value: NotTracked grey, Inferred amber, Tracked green, High blue."""


def save_figure(fig: "plt.Figure", path: str | os.PathLike, dpi: int = 110) -> None:
    """Render ``fig`` to PNG at ``path`` atomically and close it."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight")
    plt.close(fig)
    write_bytes_atomic(path, buf.getvalue())


def plot_top_view(recording: Recording, poses: Mapping[str, np.ndarray], joints_world: np.ndarray, path: Path, *,
                  facing_yaw: float | None = None, title: str = "Rig and subject, top view") -> None:
    """Top view (world xy, metres): cameras with their horizontal field of view, and the subject.

    Parameters
    ----------
    recording : the run (camera intrinsics, skeleton topology).
    poses : camera name -> (4, 4) pose in the world frame.
    joints_world : (T, J, 3) [m] the subject's joints in the world frame (NaN where absent); the pelvis
        path and the first frame with a pelvis are drawn.
    facing_yaw : [rad] the subject's facing at that frame, drawn as an arrow when given.
    """
    fig, ax = plt.subplots(figsize=(6.5, 6.5))
    topo = recording.topology
    for name, T in poses.items():
        intr = recording.camera(name).intrinsics
        half = np.arctan(intr.width / 2 / intr.fx)
        c = T[:3, 3]
        fwd = T[:3, 2]
        heading = np.arctan2(fwd[1], fwd[0])
        reach = 3.0
        for a in (heading - half, heading + half):
            ax.plot([c[0], c[0] + reach * np.cos(a)], [c[1], c[1] + reach * np.sin(a)], color="#90a4ae", lw=0.8)
        ax.plot(*c[:2], "s", color="#37474f", ms=9)
        ax.annotate(name, c[:2], textcoords="offset points", xytext=(6, 6), fontsize=9)
        ax.arrow(c[0], c[1], 0.35 * np.cos(heading), 0.35 * np.sin(heading), head_width=0.06, color="#37474f")
    pelvis = joints_world[:, topo.index(Landmark.PELVIS), :2]
    ax.plot(pelvis[:, 0], pelvis[:, 1], color="#ef9a9a", lw=0.8, label="pelvis path")
    seen = np.flatnonzero(np.isfinite(pelvis).all(axis=1))
    if seen.size:
        first = joints_world[seen[0]]
        for p, c in topo.bones:
            ax.plot(first[[p, c], 0], first[[p, c], 1], color="#c62828", lw=1.5)
        if facing_yaw is not None:
            ax.arrow(*pelvis[seen[0]], 0.3 * np.cos(facing_yaw), 0.3 * np.sin(facing_yaw), head_width=0.05,
                     color="#c62828", label="facing")
    ax.set_aspect("equal")
    ax.set_xlabel("world x [m]")
    ax.set_ylabel("world y [m]")
    ax.set_title(f"{title} (subject at its first frame)")
    ax.legend(loc="lower right", fontsize=8)
    ax.grid(alpha=0.3)
    save_figure(fig, path)


def _busiest_depth_frame(cam: CameraRecording) -> int:
    """Index of the depth frame with the most body pixels (frames read one at a time)."""
    depth = cam.depth
    counts = [np.count_nonzero(depth.labels[k] == 1 if depth.labels is not None else depth.depth_mm[k] > 0)
              for k in range(depth.n_frames)]
    return int(np.argmax(counts))


def plot_camera_view(cam: CameraRecording, path: Path) -> None:
    """Depth image [mm] of the frame with most body pixels, with the nearest skeleton projected."""
    k = _busiest_depth_frame(cam)
    depth = cam.depth.depth_mm[k].astype(float)
    depth[depth == 0] = np.nan
    fig, ax = plt.subplots(figsize=(7, 6))
    im = ax.imshow(depth, cmap="viridis", interpolation="nearest")
    fig.colorbar(im, ax=ax, shrink=0.8, label="depth [mm] (white = no return)")
    title = f"{cam.name}: depth at t = {cam.depth.timestamps[k]:.2f} s"
    if cam.skeleton is not None and cam.skeleton.n_frames:
        sk = cam.skeleton
        f = int(np.argmin(np.abs(sk.timestamps - cam.depth.timestamps[k])))
        uv, _ = cam.intrinsics.project(sk.positions[f])
        for p, c in sk.topology.bones:
            ax.plot(uv[[p, c], 0], uv[[p, c], 1], color="white", lw=1.0, alpha=0.8)
        for state in TrackingState:
            sel = sk.states[f] == state
            if sel.any() and state != TrackingState.NOT_TRACKED:
                ax.scatter(uv[sel, 0], uv[sel, 1], s=22, color=STATE_COLOURS[int(state)], edgecolor="black",
                           linewidth=0.5, label=state.name.lower().replace("_", " "), zorder=3)
        ax.legend(loc="lower right", fontsize=8)
        title += f", skeleton at t = {sk.timestamps[f]:.2f} s"
    ax.set_title(title, fontsize=10)
    ax.set_xlabel("u [px]")
    ax.set_ylabel("v [px]")
    save_figure(fig, path)


def _depth_views(recording: Recording, out_dir: Path) -> list[Path]:
    written = []
    for cam in recording.cameras:
        if cam.depth is not None and cam.depth.n_frames:
            written.append(out_dir / f"depth_{cam.name}.png")
            plot_camera_view(cam, written[-1])
    return written


def show_run(recording: Recording, truth: GroundTruth, out_dir: Path) -> list[Path]:
    """Write ``top_view.png`` (true camera poses and joints) and ``depth_<camera>.png`` (cameras with
    depth) of a simulated run into ``out_dir``."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    plot_top_view(recording, {c.name: c.T_world_cam for c in truth.cameras}, truth.joints_world,
                  out_dir / "top_view.png", facing_yaw=float(truth.facing_yaw[0]), title="Rig and subject (truth)")
    return [out_dir / "top_view.png", *_depth_views(recording, out_dir)]


def show_recording(recording: Recording, calibration: Calibration, out_dir: Path) -> list[Path]:
    """The same pictures of a recording without ground truth: camera poses from ``calibration`` and the
    subject as its reference camera reports it, in the calibration's world frame."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    ref = recording.camera(calibration.reference)
    if ref.skeleton is None:
        raise BadInputError(f"the reference camera {calibration.reference} has no skeleton stream to draw")
    poses = {n: T for n, T in calibration.T_world_cam.items() if n in recording.camera_names}
    joints = apply(calibration.T_world_cam[calibration.reference], ref.skeleton.positions)
    plot_top_view(recording, poses, joints, out_dir / "top_view.png",
                  title=f"Rig (calibrated) and subject (seen by {calibration.reference})")
    return [out_dir / "top_view.png", *_depth_views(recording, out_dir)]


_LIMB_VIEWS = (("world x-z", 0), ("world y-z", 1))


def plot_limb_axes(views: CameraViews, recording: Recording, calibration: Calibration, axes: LimbAxes, path: Path,
                   options: LimbAxisOptions = LimbAxisOptions()) -> int | None:
    """Draw the limb axes into ``path`` (module docstring) at the instant with the most counted fits;
    returns that instant's index into ``axes.times``, or None (nothing drawn) without depth instants."""
    if not axes.times.size:
        return None
    k = int(np.argmax(axes.counted.sum(axis=1)))
    t = float(axes.times[k])
    frame = int(np.argmin(np.abs(views.times - t)))
    targets = measurement_targets(views)[1][frame]
    corrected = targets + axes.offsets[frame]
    cloud = merge_clouds(recording, calibration, t, rng=np.random.default_rng(0), outlier=OutlierRemoval.NONE,
                         with_normals=False, tolerance_s=max(options.tolerance_s, 0.05))
    P, mask = segment_points(cloud.points, targets, views.topology, axes.segments, axes.radii_m, options)
    fig, panels = plt.subplots(1, 3, figsize=(16, 6), gridspec_kw={"width_ratios": [1, 1, 1.2]}, layout="constrained")
    joints = targets[np.isfinite(targets).all(axis=1)]
    lo, hi = joints.min(axis=0) - 0.25, joints.max(axis=0) + 0.25
    colours = plt.cm.tab10(np.arange(len(axes.segments)) % 10)
    for ax, (title, h) in zip(panels[:2], _LIMB_VIEWS):
        ax.scatter(cloud.points[:, h], cloud.points[:, 2], s=0.3, c="#cfcfcf", rasterized=True)
        for q, colour in enumerate(colours):
            pts = P[q][mask[q]]
            ax.scatter(pts[:, h], pts[:, 2], s=1.0, color=colour, rasterized=True)
            if axes.counted[k, q]:
                a, b = (corrected[j] for j in axes.segments[q])
                along = (np.array([a, b]) - axes.centres[k, q]) @ axes.directions[k, q]
                line = axes.centres[k, q] + along[:, None] * axes.directions[k, q]
                ax.plot(line[:, h], line[:, 2], color=colour, lw=2.0)
        ax.plot(targets[:, h], targets[:, 2], "x", color="#c62828", ms=5, label="tracker joints (camera mean)")
        ax.plot(corrected[:, h], corrected[:, 2], "o", mfc="none", color="#1565c0", ms=5, label="corrected from the clouds")
        ax.set_xlim(lo[h], hi[h])
        ax.set_ylim(min(lo[2], 0.0), hi[2])
        ax.set_aspect("equal")
        ax.set_xlabel("m")
        ax.set_title(f"{title}, t = {t:.2f} s")
    panels[0].legend(loc="lower left", fontsize=8)
    shares = axes.counted_share()
    panels[2].imshow(axes.counted.T, aspect="auto", interpolation="nearest", cmap="Greys", vmin=0, vmax=1,
                     extent=(axes.times[0], axes.times[-1], len(axes.names) - 0.5, -0.5))
    panels[2].set_yticks(range(len(axes.names)))
    panels[2].set_yticklabels([f"{n} ({shares[n]:.0%}, r {r * 1e3:.0f} mm)" for n, r in zip(axes.names, axes.radii_m)],
                              fontsize=8)
    panels[2].set_xlabel("time [s], reference clock")
    panels[2].set_title("depth instants whose axis fit counted (dark)")
    save_figure(fig, path)
    return k
