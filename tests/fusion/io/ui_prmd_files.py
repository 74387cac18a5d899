"""Made-up UI-PRMD files for the tests: a standing body's Kinect episode (offsets and angles) and the
writer of rows as gzip (or plain) text, as the data set stores them."""

from __future__ import annotations

import gzip
from pathlib import Path

import numpy as np

from fusion.topology import UI_PRMD


def _offsets_cm() -> np.ndarray:
    """(22, 3) a made-up standing body: root position, then parent-relative offsets [cm] (file axes)."""
    left = {"CollarLeft": (2, -0.5, 0), "UpperArmLeft": (16, 0, 0), "ForearmLeft": (28, 0, 0),
            "HandLeft": (25, 0, 0), "UpperLegLeft": (9, -5, 3), "LowerLegLeft": (0, -42, 0),
            "FootLeft": (0, -40, 0), "ToesLeft": (0, 0, 13)}
    table = {"Waist": (5, 90, -240), "Spine": (0, 25, 0), "Chest": (0, 22, 0), "Neck": (0, 1, 0),
             "Head": (0, 7, 0), "HeadTip": (0, 15, 0)}
    table |= left | {k.replace("Left", "Right"): (-x, y, z) for k, (x, y, z) in left.items()}
    return np.array([table[j] for j in UI_PRMD.joints], dtype=float)


def episode_rows(n_frames: int = 12) -> tuple[np.ndarray, np.ndarray]:
    """(T, 66) positions and angles rows of a made-up Kinect episode: the arms hanging, the left one
    abducting, the right elbow bent, the body turning a little."""
    offsets = np.tile(_offsets_cm(), (n_frames, 1, 1))
    angles = np.zeros((n_frames, 22, 3))
    lift = np.linspace(0.0, 80.0, n_frames)
    angles[:, UI_PRMD.index("UpperArmLeft"), 2] = -90.0 + lift
    angles[:, UI_PRMD.index("UpperArmRight"), 2] = 90.0
    angles[:, 0, 1] = np.linspace(-5.0, 5.0, n_frames)  # about y: the body turns
    angles[:, UI_PRMD.index("ForearmRight"), 0] = 20.0  # elbow bent forward (about x)
    return offsets.reshape(n_frames, -1), angles.reshape(n_frames, -1)


def write_rows(path: Path, rows: np.ndarray | str, *, compress: bool = True) -> Path:
    """Write UI-PRMD rows (or text) as a gzip (or plain) file, creating its folders."""
    text = rows if isinstance(rows, str) else "".join(",".join(f"{v:.6f}" for v in r) + "\n" for r in rows)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(gzip.compress(text.encode()) if compress else text.encode())
    return path
