"""Shared matplotlib set-up for report pictures (headless, atomic PNG writes)."""

from __future__ import annotations

import io
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from fusion.io.atomic import write_bytes_atomic  # noqa: E402

STATE_COLOURS = {0: "#9e9e9e", 1: "#ffb300", 2: "#2e7d32", 3: "#1565c0"}
"""Colour per TrackingState value: NotTracked grey, Inferred amber, Tracked green, High blue."""


def save_figure(fig: "plt.Figure", path: str | os.PathLike, dpi: int = 110) -> None:
    """Render ``fig`` to PNG at ``path`` atomically and close it."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight")
    plt.close(fig)
    write_bytes_atomic(path, buf.getvalue())
