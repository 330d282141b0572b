"""MJCF export: ``scene.xml`` plus meshes under ``mjcf/`` that plain ``mujoco`` loads.

The room is static (floor, wall and ceiling slabs); objects on the floor or on other objects
get a free joint, explicit mass and box-approximated inertia; objects hung from the ceiling or
a wall, and ``static`` ones, are welded to the world. Collision geometry is the objects'
convex pieces (boxes as MuJoCo boxes, other pieces as OBJ meshes); the visual mesh, when the
assets layer can provide one, is a non-colliding geom in group 2. Paths are relative, so the
folder can be moved. Frames: Z up, metres, object front along local -Y (see docs/conventions.md).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
import structlog
import trimesh

from scenemosaic.assets import HullCache, object_mesh
from scenemosaic.physics._checks import require_finite_poses
from scenemosaic.physics._hulls import HullInput, object_shape
from scenemosaic.physics._settings import SimSettings
from scenemosaic.physics._validate import is_fixed
from scenemosaic.physics._world import object_mass
from scenemosaic.scene import Scene, SceneObject

__all__ = ["export_mjcf"]

log = structlog.get_logger(__name__)


def _fmt(values: Any) -> str:
    return " ".join(f"{float(v):.9g}" for v in np.ravel(values))


def _visual_mesh(obj: SceneObject, base_dir: str | Path | None) -> trimesh.Trimesh | None:
    """Geometry of the object's visual mesh (MuJoCo reads no materials, so none are written)."""
    try:
        mesh = object_mesh(obj, base_dir)
    except Exception as exc:  # the visual is optional: the hulls still describe the object
        log.warning("mjcf_visual_mesh_failed", object_id=obj.id, error=str(exc))
        return None
    return trimesh.Trimesh(vertices=mesh.vertices, faces=mesh.faces, process=False)


def export_mjcf(
    scene: Scene,
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
    require_finite_poses(scene, "export MJCF")
    settings = settings or SimSettings()
    out = Path(out_dir)
    mesh_dir = out / "mjcf"
    mesh_dir.mkdir(parents=True, exist_ok=True)

    root = ET.Element("mujoco", model=scene.id)
    ET.SubElement(root, "compiler", angle="radian", meshdir="mjcf", autolimits="true")
    ET.SubElement(
        root,
        "option",
        timestep=f"{settings.timestep:g}",
        solver=settings.solver,
        iterations=str(settings.iterations),
        ls_iterations=str(settings.ls_iterations),
        cone=settings.cone,
        impratio=f"{settings.impratio:g}",
        integrator=settings.integrator,
        gravity=f"0 0 {-settings.gravity:g}",
    )
    asset = ET.SubElement(root, "asset")
    world = ET.SubElement(root, "worldbody")
    ET.SubElement(world, "light", pos="0 0 5", dir="0 0 -1", directional="true")
    _room(world, scene)

    for obj in scene.objects:
        shape = object_shape(obj, base_dir, cache=hull_cache, hulls=hulls)
        fixed = is_fixed(scene, obj)
        body = ET.SubElement(
            world, "body", name=obj.id, pos=_fmt(obj.pose.position), quat=_fmt(obj.pose.quaternion)
        )
        if not fixed:
            ET.SubElement(body, "freejoint", name=f"{obj.id}_free")
            mass = object_mass(obj, shape)
            size = shape.upper - shape.lower
            inertia = (
                mass
                / 12.0
                * np.array(
                    [size[1] ** 2 + size[2] ** 2, size[0] ** 2 + size[2] ** 2, size[0] ** 2 + size[1] ** 2]
                )
            )
            ET.SubElement(
                body,
                "inertial",
                pos=_fmt((shape.lower + shape.upper) / 2),
                mass=f"{mass:.9g}",
                diaginertia=_fmt(np.maximum(inertia, 1e-6)),
            )
        friction = f"{obj.sim.friction:g} 0.005 0.0001"
        for k, piece in enumerate(shape.pieces):
            name = f"{obj.id}_hull_{k}"
            if piece.box is not None:
                centre, half = piece.box
                ET.SubElement(
                    body,
                    "geom",
                    name=name,
                    type="box",
                    size=_fmt(half),
                    pos=_fmt(centre),
                    friction=friction,
                    group="3",
                )
            else:
                fname = f"{name}.obj"
                hull = trimesh.Trimesh(vertices=piece.vertices).convex_hull
                hull.export(mesh_dir / fname)
                ET.SubElement(asset, "mesh", name=name, file=fname)
                ET.SubElement(body, "geom", name=name, type="mesh", mesh=name, friction=friction, group="3")
        visual = _visual_mesh(obj, base_dir)
        if visual is not None:
            vname = f"{obj.id}_visual"
            visual.export(mesh_dir / f"{vname}.obj")
            ET.SubElement(asset, "mesh", name=vname, file=f"{vname}.obj")
            ET.SubElement(
                body,
                "geom",
                name=vname,
                type="mesh",
                mesh=vname,
                contype="0",
                conaffinity="0",
                group="2",
                mass="0",
            )
    ET.indent(root)
    path = out / "scene.xml"
    path.write_text(ET.tostring(root, encoding="unicode") + "\n")
    log.info("mjcf_exported", path=str(path), objects=len(scene.objects))
    return path


def _room(world: ET.Element, scene: Scene) -> None:
    room = scene.room
    if room is None:
        ET.SubElement(world, "geom", name="floor", type="plane", size="0 0 0.05")
        return
    pts = np.asarray(room.floor)
    lo, hi = pts.min(axis=0) - 1.0, pts.max(axis=0) + 1.0
    c, h = (lo + hi) / 2, (hi - lo) / 2
    ET.SubElement(
        world, "geom", name="floor", type="box", size=_fmt([h[0], h[1], 0.05]), pos=_fmt([c[0], c[1], -0.05])
    )
    ET.SubElement(
        world,
        "geom",
        name="ceiling",
        type="box",
        size=_fmt([h[0], h[1], 0.05]),
        pos=_fmt([c[0], c[1], room.ceiling_height + 0.05]),
        group="4",
    )
    for w in room.walls:
        mid = (np.asarray(w.start) + np.asarray(w.end)) / 2 + w.outward_normal * (w.thickness / 2)
        angle = math.atan2(float(w.direction[1]), float(w.direction[0]))
        ET.SubElement(
            world,
            "geom",
            name=f"wall_{w.id}",
            type="box",
            size=_fmt([w.length / 2 + w.thickness, w.thickness / 2, w.height / 2]),
            pos=_fmt([mid[0], mid[1], w.height / 2]),
            quat=_fmt([math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2)]),
        )
