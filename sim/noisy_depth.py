"""Compiled per-pixel pass of the depth noise model (:mod:`sim.depth_noise`) over one frame.

:func:`measure_frame` takes a frame's noise-free depth and, in one pass over its pixels, decides which
return a measurement (grazing dropouts), adds the axial noise, turns returns on depth edges near the
body into flying pixels, adds the offset, applies the range limits, rounds to millimetres and labels
the pixels. It draws from the frame's ``numpy.random.Generator`` itself, so a seed gives the same
frame in any process or thread.
"""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _edge_jump(depth, r, c, z):
    """Largest |jump| from ``depth[r, c] = z`` to a 4-neighbour in the image, and that neighbour's depth
    (the first of up, down, left, right on a tie; (0, z) where no neighbour is seen)."""
    height, width = depth.shape
    best, other = 0.0, z
    for dr, dc in ((-1, 0), (1, 0), (0, -1), (0, 1)):
        rr, cc = r + dr, c + dc
        if 0 <= rr < height and 0 <= cc < width:
            jump = abs(depth[rr, cc] - z)
            if jump > best:  # False for NaN
                best, other = jump, depth[rr, cc]
    return best, other


@numba.njit(cache=True, nogil=True, error_model="numpy")
def measure_frame(depth, floor_sigma_m, floor_drop_p, floor_label, body_pix, body_sigma_m, body_drop_p, box,
                  edges, fly, range_m, labels, rng):
    """Millimetre depths (H * W,) uint16 (0: no return) and labels (H * W,) uint8 of one noisy frame.

    Parameters
    ----------
    depth : (H, W) noise-free z-depth [m] of what each pixel sees, NaN where nothing.
    floor_sigma_m, floor_drop_p, floor_label : (H * W,) axial sigma [m], grazing dropout probability
        and label of the pixels that do not see the body.
    body_pix : (B,) flat indices of the pixels that see the body, ascending; ``body_sigma_m`` and
        ``body_drop_p`` (B,) theirs.
    box : (row start, row stop, column start, column stop) where flying pixels are looked for.
    edges : (min jump [m], jump relative to z): a pixel is on a depth edge where the jump to one of its
        4-neighbours exceeds ``max(edges[0], edges[1] * z)``.
    fly : (probability, spread): a return on an edge becomes, with that probability, a flying pixel
        moved ``U(0, spread)`` of the way across its largest jump.
    range_m : (offset, min, max) [m]: added to every return, which is kept within [min, max].
    labels : (body label, label of pixels without a return).
    rng : the frame's random source: per pixel a uniform draw where 0 < dropout p < 1, a normal
        draw for the axial noise, and on edges one or two uniform draws.
    """
    height, width = depth.shape
    n = height * width
    depth_mm = np.zeros(n, dtype=np.uint16)
    label = np.full(n, labels[1], dtype=np.uint8)
    r0, r1 = max(box[0], 0), min(box[1], height)
    c0, c1 = max(box[2], 0), min(box[3], width)
    j, p = 0, -1
    for r in range(height):
        for c in range(width):
            p += 1
            z = depth[r, c]
            if j < body_pix.shape[0] and body_pix[j] == p:
                sigma, prob, lab = body_sigma_m[j], body_drop_p[j], labels[0]
                j += 1
            elif math.isnan(z):
                continue
            else:
                sigma, prob, lab = floor_sigma_m[p], floor_drop_p[p], floor_label[p]
            if prob >= 1.0 or (prob > 0.0 and rng.random() < prob):
                continue
            m = z + sigma * rng.standard_normal()
            if fly[0] > 0.0 and r0 <= r < r1 and c0 <= c < c1:
                jump, other = _edge_jump(depth, r, c, z)
                if jump > max(edges[0], edges[1] * z) and rng.random() < fly[0]:
                    m += fly[1] * rng.random() * (other - z)
            m += range_m[0]
            if range_m[1] <= m <= range_m[2]:
                depth_mm[p] = np.uint16(np.rint(1e3 * m))
                label[p] = lab
    if j != body_pix.shape[0]:
        raise ValueError("body pixel indices must be ascending, unique and inside the image")
    return depth_mm, label
