"""A batch: every PhyScene room shipped in ``data/``, two variants each, on two worker processes.

Run: ``python examples/batch_run.py [OUT_DIR]``. Run it again and every finished job is skipped;
stop it half-way (Ctrl-C) and the next run does only what is missing. On a Ray cluster, pass
``executor="ray"`` (``pip install 'scenemosaic[ray]'``): the same jobs become Ray tasks.
"""

# %%
from __future__ import annotations

import json
import sys
from pathlib import Path

from scenemosaic.batch import run_batch

ROOMS = sorted((Path(__file__).resolve().parents[1] / "data" / "layouts" / "physcene").glob("*.json"))
out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("out/batch")

# %%
manifest = out / "rooms.jsonl"
manifest.parent.mkdir(parents=True, exist_ok=True)
manifest.write_text("".join(json.dumps({"input": str(room), "variants": 2, "seed": 0}) + "\n" for room in ROOMS[:3]), encoding="utf-8")

# %%
summary = run_batch(manifest, out / "scenes", workers=2)
for job in summary.jobs:
    print(f"{job.id:<40} {job.status:<8} {job.scenes_written} scenes in {job.wall_s:.1f} s")
print(summary.counts, f"{summary.scenes_written} scenes written")

# %%
again = run_batch(manifest, out / "scenes", workers=2)  # nothing left to do: every job is skipped
print("second run:", again.counts)
