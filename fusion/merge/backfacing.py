"""Back-facing flags corrected across calibrated cameras: each skeleton compared with the others'."""

from __future__ import annotations

import numpy as np

from fusion.arrays import nanmean, nanmedian
from fusion.errors import BadInputError
from fusion.facing import LIMB_PAIRS
from fusion.merge.views import CameraViews, unflip_back_facing


def cross_check_back_facing(views: CameraViews, *, margin: float = 0.7, passes: int = 2) -> np.ndarray:
    """Back-facing flags checked against the other calibrated cameras, (C, T) bool.

    For each camera and frame the limb joints are compared with the median of the other cameras'
    (their own back-facing skeletons relabelled first). If matching left to right is clearly cheaper
    than left to left (cost ratio below ``margin``), the skeleton is back-facing; if clearly dearer,
    it is not; otherwise, or without another camera's limbs, the flag in ``views`` is kept. Repeated
    ``passes`` times so that corrected flags improve the consensus.

    Parameters
    ----------
    views : every camera's skeletons in the world frame with single-camera flags
        (:func:`fusion.facing.detect_back_facing`).
    margin : cost ratio that counts as clear evidence, in (0, 1].
    passes : rounds of checking.
    """
    if not 0 < margin <= 1 or passes < 1:
        raise BadInputError(f"need 0 < margin <= 1 and passes >= 1, got {margin}, {passes}")
    topo = views.topology
    li = topo.indices([a for a, _ in LIMB_PAIRS])
    ri = topo.indices([b for _, b in LIMB_PAIRS])
    raw = views.positions
    flags = views.back_facing.copy()
    C = views.n_cameras
    if C < 2:
        return flags
    for _ in range(passes):
        fixed = unflip_back_facing(type(views)(views.names, topo, views.times, raw, views.states, views.centres, flags))
        new = flags.copy()
        for c in range(C):
            others = np.delete(np.arange(C), c)
            cons_l = nanmedian(fixed.positions[others][:, :, li], axis=0)  # NaN without another camera
            cons_r = nanmedian(fixed.positions[others][:, :, ri], axis=0)
            own_l, own_r = raw[c][:, li], raw[c][:, ri]
            direct = nanmean(np.concatenate([np.linalg.norm(own_l - cons_l, axis=-1),
                                                   np.linalg.norm(own_r - cons_r, axis=-1)], axis=1), axis=1)
            swapped = nanmean(np.concatenate([np.linalg.norm(own_l - cons_r, axis=-1),
                                                    np.linalg.norm(own_r - cons_l, axis=-1)], axis=1), axis=1)
            with np.errstate(invalid="ignore"):
                new[c] = np.where(swapped < margin * direct, True, np.where(direct < margin * swapped, False, flags[c]))
        if np.array_equal(new, flags):
            break
        flags = new
    return flags
