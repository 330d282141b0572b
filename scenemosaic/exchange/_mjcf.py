"""MJCF export: ``scene.xml`` plus meshes under ``mjcf/`` that plain ``mujoco`` loads.

The model is the one validation simulates (:func:`scenemosaic.physics.scene_world`): the room
static (floor, wall and ceiling slabs); objects on the floor or on other objects with a free
joint, explicit mass and box inertia; objects hung from the ceiling or a wall, and ``static``
ones, welded to the world. Collision geometry is the objects' convex pieces (group 3); the
visual mesh, when the assets layer can provide one, is a non-colliding geom in group 2, in the
object's category colour (``render.category_color``, as in the GLB, USD, URDF and plans). Paths
are relative, so the folder can be moved. Frames: Z up, metres, object front along local -Y
(see docs/conventions.md). :func:`export_mjcf` of a house writes a whole house as one such world.
"""

from __future__ import annotations

from pathlib import Path

from scenemosaic.assets import HullCache
from scenemosaic.physics import HullInput, SimSettings, write_house_mjcf, write_scene_mjcf
from scenemosaic.scene import House, Scene

__all__ = ["export_mjcf"]


def export_mjcf(
    scene: Scene | House,
    out_dir: str | Path,
    base_dir: str | Path | None = None,
    *,
    hull_cache: HullCache | None = None,
    hulls: HullInput | None = None,
    settings: SimSettings | None = None,
) -> Path:
    """Write ``out_dir/scene.xml`` and ``out_dir/mjcf/*.obj``; return the XML path.

    Raises :class:`~scenemosaic.exceptions.PhysicsError` naming any object whose pose is not
    finite, before anything is written (MuJoCo cannot load a ``nan`` position).
    """
    if isinstance(scene, House):  # a whole house: every room in one world
        return _export_house_mjcf(scene, out_dir, base_dir, hull_cache=hull_cache, hulls=hulls, settings=settings)
    return write_scene_mjcf(scene, out_dir, base_dir, hull_cache=hull_cache, hulls=hulls, sim=settings)


def _export_house_mjcf(
    house: House,
    out_dir: str | Path,
    base_dir: str | Path | None = None,
    *,
    hull_cache: HullCache | None = None,
    hulls: HullInput | None = None,
    settings: SimSettings | None = None,
) -> Path:
    """Write a whole house as ``out_dir/scene.xml`` and ``out_dir/mjcf/*.obj``; return the XML path
    (:func:`scenemosaic.physics.write_house_mjcf`: one floor, every room's walls with their doors
    and windows cut and shared walls once, each room's ceiling, every object)."""
    return write_house_mjcf(house, out_dir, base_dir, hull_cache=hull_cache, hulls=hulls, sim=settings)
