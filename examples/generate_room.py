"""Turn a real 3D-FRONT layout into a structured, stabilized scene from Python.

Run: ``python examples/generate_room.py [LAYOUT.json] [OUT_DIR]``
(default: the 6-object dining room shipped in ``data/``). A whole house (a ProcTHOR ``house.json``)
works too: each room's tree is printed.
"""

# %%
from __future__ import annotations

import sys
from pathlib import Path

import scenemosaic as sm
from scenemosaic.scene import House

DEFAULT = Path(__file__).resolve().parents[1] / "data/layouts/physcene/DiningRoom-19325_diningroom.json"


# %%
def main() -> None:
    source = Path(sys.argv[1]) if len(sys.argv) > 1 else DEFAULT
    out = Path(sys.argv[2]) if len(sys.argv) > 2 else Path("out/dining_room")
    result = sm.generate(source, out, sm.GenerateConfig(model="rules", seed=0))
    rooms = result.scene.rooms if isinstance(result.scene, House) else [result.scene]  # a house's, or the one
    units = sum(len(s.structure.units) if s.structure else 0 for s in rooms)
    print(f"{len(result.scene.objects)} objects in {len(rooms)} room(s), {units} units")
    for stage in result.report["stages"]:
        print(f"  {stage['name']:<10} {stage['seconds']:.2f} s")
    for scene in rooms:
        print(sm.format_tree(scene))


if __name__ == "__main__":
    main()
