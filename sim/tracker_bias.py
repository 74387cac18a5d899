"""The simulated tracker's static biases switched on, off, or off by part: what limits an angle error."""

from __future__ import annotations

import dataclasses
import enum

import numpy as np

from sim.tracker_noise import GroupNoise, JointGroup, TrackerNoise


class TrackerBias(enum.Enum):
    """The simulated tracker's static biases, or one part of them switched off."""

    ON = "on"
    OFF = "off"
    MODEL_OFF = "model-off"
    """The body-model part (shared by every camera, fixed in the body frame, with the hips' offsets
    and the arm and trunk biases) off; the view-dependent part kept at its size."""
    VIEW_OFF = "view-off"
    """The view-dependent part (per camera, along the viewing ray) off; the body-model part kept."""
    ARMS_OFF = "arms-off"
    """Both parts off for the shoulders, elbows, knees, wrists and hands (limb and hand groups)."""


def tracker_with(noise: TrackerNoise, bias: TrackerBias) -> TrackerNoise:
    """``noise`` with its static biases as ``bias`` says (jitter, wobble, outliers, inferred offsets
    and flips kept)."""
    f = noise.model_fraction

    def scaled(groups: tuple[JointGroup, ...], factor: float) -> dict[JointGroup, GroupNoise]:
        return {g: dataclasses.replace(n, bias_m=tuple(factor * np.asarray(n.bias_m))) if g in groups else n
                for g, n in noise.groups.items()}

    every = tuple(JointGroup)
    if bias is TrackerBias.ON:
        return noise
    if bias is TrackerBias.OFF:
        return dataclasses.replace(noise, groups=scaled(every, 0.0), hip_up_m=0.0, hip_out_m=0.0, arm_bias=None,
                                   trunk_bias=None)
    if bias is TrackerBias.MODEL_OFF:
        return dataclasses.replace(noise, groups=scaled(every, np.sqrt(1.0 - f)), model_fraction=0.0,
                                   hip_up_m=0.0, hip_out_m=0.0, arm_bias=None, trunk_bias=None)
    if bias is TrackerBias.VIEW_OFF:
        return dataclasses.replace(noise, groups=scaled(every, np.sqrt(f)), model_fraction=1.0)
    return dataclasses.replace(noise, groups=scaled((JointGroup.LIMB, JointGroup.HAND), 0.0), arm_bias=None)
