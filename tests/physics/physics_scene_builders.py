"""Test-only scene builders for the physics tests and benchmark.

Stand-ins until the real importer / structuring / hull cache land:

* ``load_physcene_scene`` reads a 3D-FRONT/PhyScene layout (half extents, Y-up, bottom-centre
  positions) into a Z-up scene with procedural assets and a room rectangle 0.3 m around the
  footprints;
* ``assign_supports`` is a tiny support rule (ceiling/pendant lamps on the ceiling, the rest on
  the floor);
* ``sam3d_scene`` builds bed, desk, chair, printer and mug from the real SAM3D meshes with
  perturbations, and ``sam3d_hulls`` gives CoACD pieces for them, cached on disk under
  ``.scenemosaic-cache/physics-tests``.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from scenemosaic.scene import AssetRef, Pose, Relation, Room, Scene, SceneObject, SimAttributes

REPO_ROOT = Path(__file__).resolve().parents[2]
SAM3D_DIR = (REPO_ROOT.parent / "shared" / "data" / "sam3d_objects").resolve()
CACHE_DIR = REPO_ROOT / ".scenemosaic-cache" / "physics-tests"
MARGIN_M = 0.3

_HANGING = ("ceiling_lamp", "pendant_lamp")


def load_physcene_scene(path: Path) -> Scene:
    """A Z-up scene from one PhyScene/3D-FRONT layout file."""
    data = json.loads(path.read_text())
    objects: list[SceneObject] = []
    counts: dict[str, int] = {}
    for items in data["ThreedFront"].values():
        for item in items:
            label = str(item["label"])
            k = counts.get(label, 0)
            counts[label] = k + 1
            sx, sy, sz = (float(v) for v in item["size"])
            x, y, z = (float(v) for v in item["position"])
            objects.append(
                SceneObject(
                    id=f"{label}_{k}",
                    category=label,
                    asset=AssetRef(kind="procedural", category=label, extents=(2 * sx, 2 * sz, 2 * sy)),
                    pose=Pose.from_yaw((x, -z, y), float(item["theta"])),
                )
            )
    feet = np.concatenate([o.footprint() for o in objects])
    lo, hi = feet.min(axis=0) - MARGIN_M, feet.max(axis=0) + MARGIN_M
    top = max(float(o.aabb()[1][2]) for o in objects)
    height = max(2.8, math.ceil(top * 100) / 100)
    room = Room.rectangle(float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]), ceiling_height=height)
    return Scene(id=path.stem.replace(" ", "_"), room=room, objects=objects)


def assign_supports(scene: Scene) -> Scene:
    """Ceiling and pendant lamps hang from the ceiling; everything else stands on the floor."""
    relations = [
        Relation(
            kind="attach", child=o.id, parent="ceiling" if o.category in _HANGING else "floor", source="test"
        )
        for o in scene.objects
        if scene.support_of(o.id) is None
    ]
    return scene.model_copy(update={"relations": [*scene.relations, *relations]})


# -- SAM3D -----------------------------------------------------------------------------------
SAM3D_MESHES = {
    "king_bed": "generated_assets/sdf/king_bed_1761578419/king_bed.gltf",
    "work_desk": "generated_assets/sdf/work_desk_1761578426/work_desk.gltf",
    "office_chair": "generated_assets/sdf/office_chair_1761578426/office_chair.gltf",
    "printer": "generated_assets/sdf/printer_1761578426/printer.gltf",
    "coffee_mug": "generated_assets/manipulands/sdf/coffee_mug_1762992163/coffee_mug.gltf",
}
_Y_UP_TO_Z_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


def canonical_mesh(name: str) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (Z-up, bottom centre at the origin) and faces of one SAM3D mesh."""
    import trimesh

    mesh = trimesh.load(SAM3D_DIR / SAM3D_MESHES[name]).to_geometry()
    v = np.asarray(mesh.vertices, dtype=np.float64) @ _Y_UP_TO_Z_UP.T
    lo, hi = v.min(axis=0), v.max(axis=0)
    v -= np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]])
    return v, np.asarray(mesh.faces, dtype=np.int64)


def canonical_hulls(name: str) -> list[np.ndarray]:
    """Convex pieces of one canonical SAM3D mesh, cached on disk.

    CoACD on the simplified mesh; when the pieces do not cover the mesh's bounds (open,
    shell-like scans such as the printer and the mug give slivers) or come out in dozens,
    the single convex hull of the mesh is used instead.
    """
    CACHE_DIR.mkdir(parents=True, exist_ok=True)
    path = CACHE_DIR / f"{name}.npz"
    if path.exists():
        with np.load(path) as z:
            return [z[k] for k in sorted(z.files, key=lambda s: int(s.split("_")[1]))]
    import coacd
    import fast_simplification
    from scipy.spatial import ConvexHull

    v, f = canonical_mesh(name)
    sv, sf = fast_simplification.simplify(v.astype(np.float32), f, target_count=1500)
    coacd.set_log_level("error")
    parts = coacd.run_coacd(
        coacd.Mesh(np.asarray(sv, dtype=np.float64), np.asarray(sf, dtype=np.int64)),
        threshold=0.08,
        max_convex_hull=16,
        preprocess_resolution=30,
        resolution=1000,
        mcts_iterations=60,
        mcts_max_depth=2,
        mcts_nodes=10,
        seed=0,
    )
    pieces = [np.asarray(p[0], dtype=np.float64) for p in parts]
    full = v.max(axis=0) - v.min(axis=0)
    allp = np.concatenate(pieces) if pieces else v[:0]
    covered = (allp.max(axis=0) - allp.min(axis=0)) / full if len(allp) else np.zeros(3)
    hull_volume = ConvexHull(v).volume
    piece_volume = sum(ConvexHull(p).volume for p in pieces if len(p) >= 4)
    if len(pieces) > 32 or np.any(covered < 0.9) or piece_volume < 0.3 * hull_volume:
        pieces = [v[ConvexHull(v).vertices]]
    np.savez(path, **{f"piece_{i}": p for i, p in enumerate(pieces)})
    return pieces


def canonical_extents(name: str) -> tuple[float, float, float]:
    v, _ = canonical_mesh(name)
    e = v.max(axis=0) - v.min(axis=0)
    return (float(e[0]), float(e[1]), float(e[2]))


def sam3d_scene(seed: int = 0) -> tuple[Scene, dict[str, list[np.ndarray]]]:
    """Bed, desk and chair on the floor, printer and mug on the desk, perturbed; plus their hull pieces.

    Perturbations (seeded): the chair driven 5–15 cm into the desk, the mug 5–15 cm into the
    printer, the bed 5-15 cm into the desk's side, and every object lifted 2–10 cm off its support.
    """
    rng = np.random.default_rng(seed)
    hulls_c = {n: canonical_hulls(n) for n in SAM3D_MESHES}
    extents: dict[str, tuple[float, float, float]] = {}
    for n, pieces in hulls_c.items():
        allv = np.concatenate(pieces)
        e = allv.max(axis=0) - allv.min(axis=0)
        extents[n] = (float(e[0]), float(e[1]), float(e[2]))
    scale = {"printer": (0.5, 0.5, 0.5)}
    masses = {"king_bed": 60.0, "work_desk": 23.0, "office_chair": 12.0, "printer": 6.0, "coffee_mug": 0.3}

    def lift() -> float:
        return float(rng.uniform(0.02, 0.10))

    def dig() -> float:
        return float(rng.uniform(0.05, 0.15))

    bed_w, bed_d, _ = extents["king_bed"]
    desk_w, desk_d, desk_h = extents["work_desk"]
    chair_d = extents["office_chair"][1]
    printer_w = extents["printer"][0] * 0.5
    bed_x = -2.45 + bed_w / 2
    bed_y = 2.45 - bed_d / 2
    desk_x = bed_x + bed_w / 2 + desk_w / 2 - dig()  # desk driven into the bed's side
    desk_y = 2.45 - desk_d / 2
    chair_y = desk_y - desk_d / 2 - chair_d / 2 + 0.3 + dig()  # chair pushed into the desk
    printer_x = desk_x + 0.3
    mug_x = printer_x - printer_w / 2 + dig() / 2  # mug inside the printer
    desk_z = lift()
    layout = {
        "king_bed": ((bed_x, bed_y, lift()), 0.0, "floor"),
        "work_desk": ((desk_x, desk_y, desk_z), 0.0, "floor"),
        "office_chair": ((desk_x - 0.1, chair_y, lift()), math.pi, "floor"),
        "printer": ((printer_x, desk_y, desk_z + desk_h + lift()), 0.0, "work_desk"),
        "coffee_mug": ((mug_x, desk_y - 0.1, desk_z + desk_h + lift()), 0.3, "work_desk"),
    }
    objects = []
    relations = []
    hulls: dict[str, list[np.ndarray]] = {}
    for name, (pos, yaw, parent) in layout.items():
        s = scale.get(name, (1.0, 1.0, 1.0))
        objects.append(
            SceneObject(
                id=name,
                category=name,
                asset=AssetRef(kind="mesh", uri=SAM3D_MESHES[name], extents=extents[name]),
                pose=Pose.from_yaw(pos, yaw, scale=s),
                sim=SimAttributes(mass_kg=masses[name], friction=0.5, source="scenesmith sdf"),
            )
        )
        relations.append(Relation(kind="attach", child=name, parent=parent, source="test"))
        hulls[name] = [p * np.asarray(s) for p in hulls_c[name]]
    room = Room.rectangle(-2.5, -2.5, 2.5, 2.5, ceiling_height=2.8)
    return Scene(id="sam3d_office", room=room, objects=objects, relations=relations), hulls
