"""Turn a real 3D-FRONT layout into a structured, stabilized scene from Python.

Run: ``python examples/generate_room.py [LAYOUT.json] [OUT_DIR]``
(default: the 6-object dining room shipped in ``data/``).
"""

# %%
from __future__ import annotations

import sys
from pathlib import Path

import scenemosaic as sm

DEFAULT = Path(__file__).resolve().parents[1] / "data/layouts/physcene/DiningRoom-19325_diningroom.json"


# %%
def main() -> None:
    source = Path(sys.argv[1]) if len(sys.argv) > 1 else DEFAULT
    out = Path(sys.argv[2]) if len(sys.argv) > 2 else Path("out/dining_room")
    result = sm.generate(source, out, sm.GenerateConfig(model="rules", seed=0))
    scene = result.scene
    print(f"{len(scene.objects)} objects, {len(scene.structure.units if scene.structure else [])} units")
    for stage in result.report["stages"]:
        print(f"  {stage['name']:<10} {stage['seconds']:.2f} s")
    print(sm.format_tree(scene))


if __name__ == "__main__":
    main()
