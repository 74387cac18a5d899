"""The picture of a fusion's limb axes (``limb_axes.png`` of ``fuse --limb-axes``): one depth instant's
limb points with their fitted axes, the tracker's joints and the corrected ones, seen along the world's x
and y axes; and, per segment, at which instants of the session a fit counted."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fusion.calibration import Calibration
from fusion.merge.cloud import OutlierRemoval, merge_clouds
from fusion.merge.kinematic import measurement_targets
from fusion.merge.limb_axes import LimbAxisOptions, segment_points
from fusion.merge.limb_corrections import LimbAxes
from fusion.merge.views import CameraViews
from fusion.recording import Recording
from scenarios.show import plt, save_figure

_VIEWS = (("world x-z", 0), ("world y-z", 1))


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
    for ax, (title, h) in zip(panels[:2], _VIEWS):
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
        ax.plot(corrected[:, h], corrected[:, 2], "o", mfc="none", color="#1565c0", ms=5, label="on the limb axes")
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
