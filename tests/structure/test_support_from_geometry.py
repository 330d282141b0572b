"""Support inferred from geometry matches the ProcTHOR generator's own nesting (read only to score)."""

from __future__ import annotations

import re
from pathlib import Path

from scenemosaic.exchange import load_scenes
from scenemosaic.scene import Scene
from scenemosaic.structure import structure_scene

HOUSES = Path(__file__).resolve().parents[2] / "data" / "houses" / "procthor"


def _read_parents(out: Scene) -> dict[str, str]:
    """Each object's parent as the agents *read* it: verification's deliberate re-homings (listed
    in the notes as ``verify: X -> Y (why; was on Z)``) are undone, so the reading is scored."""
    read = {r.child: r.parent for r in out.relations if r.is_support}
    for note in out.provenance.notes:
        m = re.match(r"verify: (\S+) -> (\S+) \(.*; was on (\S+)\)$", note)
        if m and m.group(3) != "nothing":
            read[m.group(1)] = m.group(3)
    return read


async def _inferred_vs_truth() -> tuple[int, int, list[tuple[str, str, str | None, str]], int]:
    total = matched = moved = 0
    misses: list[tuple[str, str, str | None, str]] = []
    for path in sorted(HOUSES.glob("procthor*.json")):
        for scene in load_scenes(path):
            truth = {r.child: r.parent for r in scene.relations if r.is_support}
            bare = scene.model_copy(update={"relations": []})  # the nesting is not shown to the agents
            out = await structure_scene(bare)
            got = _read_parents(out)
            final = {r.child: r.parent for r in out.relations if r.is_support}
            moved += sum(1 for k in truth if final.get(k) != got.get(k))
            for child, parent in truth.items():
                total += 1
                if got.get(child) == parent:
                    matched += 1
                else:
                    misses.append((path.stem, child, got.get(child), parent))
    return matched, total, misses, moved


async def test_support_matches_the_generators_nesting_on_the_procthor_houses() -> None:
    matched, total, misses, moved = await _inferred_vs_truth()
    assert total >= 300  # the nested items of six real houses, 27 rooms
    assert matched / total >= 0.95, misses
    assert moved > 0  # crowded tops and implausible receptacles were re-homed, each with its reason
    # the generator's own imprecision: baseball bats lying on the floor while listed under furniture
    for house, child, got, _listed in misses:
        scene = next(s for s in load_scenes(HOUSES / f"{house}.json") if any(o.id == child for o in s.objects))
        obj = scene.get(child)
        assert obj.category == "baseball_bat" and obj.pose.position[2] < 0.05 and got == "floor", (house, child)


def _pillow_on_bed() -> Scene:
    from scenemosaic.scene import AssetRef, Pose, Room, SceneObject

    bed = SceneObject(
        id="bed",
        category="double_bed",
        asset=AssetRef(kind="procedural", category="double_bed", extents=(1.6, 2.1, 1.0)),
        pose=Pose.from_yaw((2.0, 2.0, 0.0), 0.0),
    )
    return Scene(id="bedroom", room=Room.rectangle(0, 0, 4, 4, ceiling_height=2.6), objects=[bed])


async def test_a_pillow_at_mattress_height_rests_on_the_bed_not_the_floor() -> None:
    """The bed's box top (with its headboard) is far above the mattress: only its mesh shows the surface."""
    from scenemosaic.assets import object_mesh
    from scenemosaic.scene import AssetRef, Pose, SceneObject
    from scenemosaic.structure._support import _vertical_hits

    scene = _pillow_on_bed()
    bed = scene.get("bed")
    mesh = object_mesh(bed)
    # the mattress top under the bed's centre, measured independently on the same mesh
    hits = _vertical_hits(mesh, [[0.0, 0.0]])[0]
    mattress = float(hits.max())
    assert mattress < 0.9 * bed.size[2], "the stand-in bed should have a headboard above its mattress"
    pillow = SceneObject(
        id="pillow",
        category="pillow",
        asset=AssetRef(kind="procedural", category="pillow", extents=(0.5, 0.3, 0.12)),
        pose=Pose.from_yaw((2.0, 2.0, mattress), 0.0),
    )
    scene.objects.append(pillow)
    out = await structure_scene(scene)
    assert out.support_of("pillow") is not None and out.support_of("pillow").parent == "bed"
