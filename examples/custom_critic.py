"""A custom critic rule: keep the coffee table in front of the sofa.

Run: ``python examples/custom_critic.py [ROOM.json] [OUT]`` (default: the living room
LivingDiningRoom-8714 shipped in ``data/``). The rule is a plain function the evolve stage's critic
calls on every layout of every unit; what it finds joins the built-in findings, the rule actor
applies its fix, and a real VLM critic reads its note. On a whole house (a ProcTHOR ``house.json``)
it runs in every room, and each room with a sofa and a coffee table is measured.
"""

# %%
from __future__ import annotations

import math
import sys
from pathlib import Path

import scenemosaic as sm
from scenemosaic.evolve import Finding, Target, UnitContext
from scenemosaic.scene import UnitLayout

ROOM = Path(__file__).resolve().parents[1] / "data/layouts/physcene/LivingDiningRoom-8714_livingroom.json"
GAP = 0.30  # metres of legroom between the sofa's front and the table
TOLERANCE = 0.05  # metres the table may stand off that place


def _front(rotation: float) -> tuple[float, float]:
    """The way an object faces in a unit's view (rotation 0 faces down the view)."""
    r = math.radians(rotation)
    return -math.sin(r), -math.cos(r)


def coffee_table_in_front(layout: UnitLayout, ctx: UnitContext) -> list[Finding]:
    """A coffee table belongs ``GAP`` in front of the middle of the sofa."""
    if ctx.unit.anchor_kind != "floor":
        return []
    sofas = [k for k in layout.ids if "sofa" in layout.object(k).category]
    tables = [k for k in layout.ids if layout.object(k).category == "coffee_table"]
    out = []
    for table, sofa in zip(tables, sofas, strict=False):
        fu, fv = _front(layout.rotation(sofa))
        (su, sv), (tu, tv) = layout.center(sofa), layout.center(table)
        # how far the sofa's box reaches forward from its centre, and the table's box backward
        sofa_reach = max((u - su) * fu + (v - sv) * fv for u, v in layout.polygon(sofa))
        table_reach = max(-((u - tu) * fu + (v - tv) * fv) for u, v in layout.polygon(table))
        reach = sofa_reach + GAP + table_reach
        want = (su + fu * reach, sv + fv * reach)
        if math.dist(want, (tu, tv)) > TOLERANCE:
            out.append(
                Finding(
                    kind="coffee_table", objects=(table, sofa), severity="semantic",
                    note=f"Put ({table}) right in front of the sofa ({sofa}), {GAP:.2f} m from its seat.",
                    fixes={table: Target(want[0], want[1])},
                )
            )
    return out


# %%
def evolved_layouts(result: sm.GenerateResult, room_id: str) -> list[tuple[str, str, bool]]:
    """What the evolve stage made of each unit: its anchor, the layout chosen, whether valid."""
    stages = result.room_report(room_id)["stages"]  # a room of a house or a room run alike
    layouts = next(s for s in stages if s["name"] == "evolve")["detail"]["layouts"]
    return [(lay["anchor"], lay["layout_id"], lay["valid"]) for lay in layouts]


def main() -> None:
    source = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOM
    out = Path(sys.argv[2]) if len(sys.argv) > 2 else Path("out/custom_critic")
    plain = sm.generate(source, out / "plain", sm.GenerateConfig(overwrite=True))
    ruled = sm.generate(source, out / "ruled", sm.GenerateConfig(layout_rules=[coffee_table_in_front], overwrite=True))
    for name, result in (("built-in rules", plain), ("with the plugin", ruled)):
        measured = 0
        for room_id in result.rooms:  # a whole house's rooms, or the one room of a room run
            scene = result.room(room_id)
            sofa = next((o for o in scene.objects if "sofa" in o.category), None)
            table = next((o for o in scene.objects if o.category == "coffee_table"), None)
            if sofa is None or table is None:
                continue
            gap = math.dist(sofa.pose.position[:2], table.pose.position[:2])
            print(f"{name} ({room_id}): coffee table {gap:.2f} m from the sofa's centre, status {result.status}")
            measured += 1
        if not measured:
            print(f"{name}: no room with both a sofa and a coffee table (the rule finds nothing), status {result.status}")
    for room_id in ruled.rooms:
        print(f"evolved layouts of {room_id}: {evolved_layouts(ruled, room_id)}")


if __name__ == "__main__":
    main()
