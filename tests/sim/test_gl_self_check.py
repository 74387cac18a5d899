"""The self-check of MuJoCo's rendered depth, and ``auto`` falling back to the ray caster when it fails.

The failures are reproduced on any OpenGL by perturbing the rendered depth the ways a driver can:
a bias growing with z^2 (as measured on an NVIDIA GPU: 0.24 mm per m^2), a wrong near plane in the
linearisation, and depth taken an eighth of a pixel off the pixel centre (a multisample resolve).
"""

from __future__ import annotations

import logging

import pytest

from sim import gl_depth, gl_self_check
from sim.depth_renderer import DepthRenderer

NO_GL = gl_depth.gl_unavailable()
needs_gl = pytest.mark.skipif(NO_GL is not None, reason=f"no OpenGL context for mujoco.Renderer: {NO_GL}")
GPU = "NVIDIA H200/PCIe/SSE2"


@pytest.fixture
def fresh_check():
    gl_self_check.depth_self_check.cache_clear()
    yield gl_self_check.depth_self_check
    gl_self_check.depth_self_check.cache_clear()


@needs_gl
def test_mujoco_depth_passes_here(fresh_check):
    assert fresh_check() is None


def _z2_bias(render):
    return lambda self, data, *box: (z := render(self, data, *box)) + 0.24e-3 * z**2


def _near_off(render):
    return lambda self, data, *box: 1.01 * render(self, data, *box)  # z = d / (w + c) scales with the near plane in d


@needs_gl
@pytest.mark.parametrize("perturb", [_z2_bias, _near_off], ids=["z2_bias", "wrong_near"])
def test_a_biased_linearisation_fails_and_auto_falls_back(monkeypatch, caplog, fresh_check, perturb):
    monkeypatch.setattr(gl_depth.GLBodyDepth, "render", perturb(gl_depth.GLBodyDepth.render))
    reason = fresh_check()
    assert reason is not None and "mm off its closed form" in reason
    monkeypatch.setattr(gl_depth, "probe_gl", lambda: (GPU, None))
    with caplog.at_level(logging.INFO):
        assert DepthRenderer.AUTO.resolve() is DepthRenderer.RAYCAST
        assert DepthRenderer.MUJOCO.resolve() is DepthRenderer.MUJOCO  # forced: renders, with a warning
    assert f"hardware OpenGL ({GPU}) but MuJoCo's depth failed its self-check" in caplog.text
    assert "depth by ray casting" in caplog.text and "rendering with it as asked" in caplog.text
    assert all(r.levelno == logging.WARNING for r in caplog.records)


@needs_gl
def test_a_box_rendered_off_its_place_fails(monkeypatch, fresh_check):
    render = gl_depth.GLBodyDepth.render

    def box_one_column_off(self, data, box=None):
        return render(self, data) if box is None else render(self, data, (box[0], box[1], box[2] + 1, box[3] + 1))

    monkeypatch.setattr(gl_depth.GLBodyDepth, "render", box_one_column_off)
    assert "mm off its closed form" in fresh_check()


@needs_gl
def test_depth_off_the_pixel_centre_fails(monkeypatch, fresh_check):
    init = gl_depth.GLBodyDepth.__init__

    def eighth_pixel_off(self, model, placement, geom_group):
        init(self, model, placement, geom_group)
        self._gl["frustum_center"] += self._gl["frustum_near"] * 0.125 / placement.intrinsics.fx

    monkeypatch.setattr(gl_depth.GLBodyDepth, "__init__", eighth_pixel_off)
    assert "mm off its closed form" in fresh_check()


def test_a_failed_render_fails_the_check(monkeypatch, fresh_check):
    def no_context(self, model, placement, geom_group):
        raise RuntimeError("no display")

    monkeypatch.setattr(gl_depth.GLBodyDepth, "__init__", no_context)
    assert fresh_check() == "the check's render failed: RuntimeError: no display"
