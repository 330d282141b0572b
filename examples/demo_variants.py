"""The demo, from Python: a 16-object bedroom-study, made physically valid, with five variants.

Run: ``python examples/demo_variants.py [OUT_DIR]`` (offline: the rules model, no key). Each
``# %%`` cell runs on its own in a notebook; there the result displays as a table over the
contact sheet of the base scene and its variants.
"""

# %%
from __future__ import annotations

import sys
from pathlib import Path

import scenemosaic as sm
from scenemosaic.exchange import save_scene

out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("out/demo_variants")
source = save_scene(sm.demo_scene(), out / "input")  # the demo's imprecise layout, as a scene file

# %%
result = sm.generate(source, out / "run", sm.GenerateConfig(variants=5, seed=0, overwrite=True))
print(f"status {result.status}: {len(result.scene.objects)} objects, {len(result.variants)} variants")

# %%
metrics = result.metrics or {}
for name, m in [("base", metrics.get("base", {})), *((f"variant_{i}", v) for i, v in enumerate(metrics.get("variants", []), 1))]:
    print(f"{name:<10} COL {m.get('COL')}  OOB {m.get('OOB')}  NAV {m.get('NAV')}  RelKeep {m.get('RelKeep', '-')}")
print("diversity:", metrics.get("diversity"))

# %%
print("contact sheet:", result.preview_path)  # in a notebook, `result` on its own line shows it
