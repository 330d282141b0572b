"""Orthographic renders with MuJoCo's offscreen renderer (EGL, OSMesa or GLFW, by ``MUJOCO_GL``).

:func:`render_meshes_gl` draws world-space triangle meshes with flat colours and lighting through
an orthographic camera that looks along ``-view.normal`` with ``view.u`` to the right and
``view.v`` up, framed exactly like :class:`~scenemosaic.render.PixelMap` frames the same view, so
overlays drawn in plane coordinates land on the geometry. When no GL context can be made (no
display, no EGL), it returns ``None`` once and every later call returns ``None`` at once: the
caller falls back to the Pillow painter.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Sequence

import numpy as np
import structlog
import trimesh

from scenemosaic.render._palette import RGB

__all__ = ["gl_available", "render_meshes_gl"]

log = structlog.get_logger(__name__)

_LOCK = threading.Lock()
_STATE: dict[str, bool] = {}


def gl_available() -> bool:
    """Whether an offscreen GL context could be made (tried once per process)."""
    if "ok" not in _STATE:
        with _LOCK:
            if "ok" not in _STATE:
                _STATE["ok"] = _probe()
    return _STATE["ok"]


def _probe() -> bool:
    try:
        import mujoco

        model = mujoco.MjModel.from_xml_string("<mujoco><worldbody><geom type='sphere' size='0.1'/></worldbody></mujoco>")
        renderer = mujoco.Renderer(model, 8, 8)
        renderer.close()
        return True
    except Exception as exc:  # no display, no EGL/OSMesa: the painter will do
        log.info("gl_unavailable", backend=os.environ.get("MUJOCO_GL", ""), error=str(exc)[:200])
        return False


def _floats(values: np.ndarray) -> str:
    return " ".join(f"{v:.6g}" for v in np.asarray(values, dtype=np.float64).ravel())


def render_meshes_gl(
    meshes: Sequence[tuple[trimesh.Trimesh, RGB]],
    *,
    center: np.ndarray,
    u: np.ndarray,
    v: np.ndarray,
    height_m: float,
    distance_m: float,
    size_px: int,
    background: RGB,
) -> np.ndarray | None:
    """An RGB image (size_px x size_px x 3) of ``meshes`` (world frame, each with a colour) seen by
    an orthographic camera at ``center + (u x v) * distance_m`` whose view is ``height_m`` tall.

    ``None`` when GL is unavailable or the render fails.
    """
    if not meshes or not gl_available():
        return None
    import mujoco

    n = np.cross(u, v)
    cam = np.asarray(center, dtype=np.float64) + n * distance_m
    assets, geoms = [], []
    for k, (mesh, color) in enumerate(meshes):
        if len(mesh.faces) == 0:
            continue
        rgba = f"{color[0] / 255:.4f} {color[1] / 255:.4f} {color[2] / 255:.4f} 1"
        assets.append(f'<mesh name="m{k}" vertex="{_floats(mesh.vertices)}" face="{_floats(mesh.faces)}" inertia="shell"/>')
        geoms.append(f'<geom type="mesh" mesh="m{k}" rgba="{rgba}" contype="0" conaffinity="0"/>')
    bg = " ".join(f"{c / 255:.4f}" for c in background)
    xml = f"""<mujoco>
  <compiler boundmass="1e-6" boundinertia="1e-9"/>
  <statistic extent="10" center="{_floats(center)}"/>
  <visual>
    <global offwidth="{size_px}" offheight="{size_px}"/>
    <map znear="0.001" zfar="10"/>
    <headlight ambient="0.45 0.45 0.45" diffuse="0.5 0.5 0.5" specular="0 0 0"/>
    <rgba haze="{bg} 1"/>
    <quality shadowsize="0"/>
  </visual>
  <asset>{"".join(assets)}</asset>
  <worldbody>
    {"".join(geoms)}
    <camera name="view" pos="{_floats(cam)}" xyaxes="{_floats(u)} {_floats(v)}" projection="orthographic" fovy="{height_m:.6g}"/>
  </worldbody>
</mujoco>"""
    with _LOCK:  # one GL context at a time: contexts are bound to the thread that made them
        try:
            model = mujoco.MjModel.from_xml_string(xml)
            data = mujoco.MjData(model)
            mujoco.mj_forward(model, data)
            renderer = mujoco.Renderer(model, size_px, size_px)
            try:
                scene_option = mujoco.MjvOption()
                renderer.update_scene(data, camera="view", scene_option=scene_option)
                image = np.asarray(renderer.render(), dtype=np.uint8).copy()
            finally:
                renderer.close()
        except Exception as exc:
            log.warning("gl_render_failed", error=str(exc)[:300])
            return None
    # the empty background: MuJoCo clears to black; paint it the view's background colour
    empty = (image == 0).all(axis=2)
    image[empty] = np.asarray(background, dtype=np.uint8)
    return image
