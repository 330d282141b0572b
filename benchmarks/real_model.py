"""Real-model benchmark: ``generate`` with a live model on the shipped rooms, against the rules run.

For every shipped PhyScene room and the SAM3D office, ``generate`` runs twice: with the offline
rules model, and with the model given (e.g. the shared llama.cpp server). Each model run records
a cassette (``<out>/<input>.cassette.json``), so it can be replayed with the server stopped. Per
input it reports the exit status, wall time, model requests and the agents' breakdown, and
whether the model run validates at least as well as the rules run: no wall lost or collapsed
(as many walls, none shorter than 0.3 m), no more colliding pairs, no more out-of-bounds
objects, nothing more tipped or fallen, the base's NAV within 0.01 of the rules'. Both runs ask for
``--variants`` (2 by default); ``within_5_min`` says whether the model run took at most 300 s, and
``model_summary`` / ``given_up`` are the report's account of the model (issue 57).

Without ``--model`` (and without ``SCENEMOSAIC_LLM_URL``, which names the server as the integration
tests do) it prints ``{"skipped": ...}``, so ``make bench`` runs on a machine with no server.

Run (server from ``../shared/tools/llm_server``, started with ``bash start.sh``)::

    .venv/bin/python benchmarks/real_model.py \
        --model openai:qwen2.5-coder-0.5b-instruct@http://127.0.0.1:8089/v1 --out /tmp/real

The last line is one JSON object: ``inputs``, ``exit_0``, ``at_least_as_valid``, ``within_5_min``,
``model_wall_s_total``, ``model_wall_s_max`` and ``per_input`` (status, wall time, requests, agents,
the model's account).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from scenemosaic.exchange import write_sam3d_example

REPO = Path(__file__).resolve().parents[1]
PHYSCENE = sorted((REPO / "data" / "layouts" / "physcene").glob("*.json"))
CLI = [sys.executable, "-m", "scenemosaic.cli"]


def _generate(source: Path, out: Path, model: str, variants: int) -> tuple[int, float]:
    started = time.perf_counter()
    done = subprocess.run(
        [*CLI, "generate", str(source), "--out", str(out), "--overwrite", "--no-vision", "--model", model,
         "--variants", str(variants)],
        capture_output=True,
        text=True,
        check=False,
    )
    (out.parent / f"{out.name}.log").write_text(done.stdout + done.stderr, encoding="utf-8")
    return done.returncode, round(time.perf_counter() - started, 1)


def _validity(out: Path) -> dict[str, Any]:
    report = json.loads((out / "report.json").read_text(encoding="utf-8"))
    scene = json.loads((out / "base" / "scene.json").read_text(encoding="utf-8"))
    walls = (scene.get("room") or {}).get("walls", [])
    lengths = [((w["end"][0] - w["start"][0]) ** 2 + (w["end"][1] - w["start"][1]) ** 2) ** 0.5 for w in walls]
    v = report.get("validation") or {}
    return {
        "status": report["status"],
        "walls": len(walls),
        "shortest_wall_m": round(min(lengths), 3) if lengths else 0.0,
        "collisions": len((v.get("collisions") or {}).get("pairs", [])),
        "out_of_bounds": len((v.get("out_of_bounds") or {}).get("objects", [])),
        "tipped_or_fell": len(v.get("tipped", [])) + len(v.get("fell", [])),
        "nav": ((report.get("metrics") or {}).get("base") or {}).get("NAV"),
        "report": report,
    }


def _structure(report: dict[str, Any]) -> dict[str, Any]:
    stage = next((s for s in report["stages"] if s["name"] == "structure"), {"detail": {}})
    return stage.get("detail", {})


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default=None, help="model spec, e.g. openai:<name>@http://127.0.0.1:8089/v1")
    parser.add_argument("--out", type=Path, default=None, help="output folder (default: a temporary one)")
    parser.add_argument("--only", default=None, help="run only inputs whose name contains this")
    parser.add_argument("--variants", type=int, default=2, help="variants per run (default 2, as issue 57 measures)")
    args = parser.parse_args(argv)
    url = os.environ.get("SCENEMOSAIC_LLM_URL")
    if args.model is None and url:
        args.model = f"openai:{os.environ.get('SCENEMOSAIC_LLM_MODEL', 'qwen2.5-coder-0.5b-instruct')}@{url}"
    if args.model is None:  # `make bench` without a server: say so, do not fail
        print(json.dumps({"skipped": "no model: give --model or set SCENEMOSAIC_LLM_URL"}))
        return 0
    if args.out is None:
        args.out = Path(tempfile.mkdtemp(prefix="real_model_"))
    args.out.mkdir(parents=True, exist_ok=True)
    inputs = {p.stem: p for p in PHYSCENE}
    inputs["sam3d_office"] = write_sam3d_example(args.out / "sam3d_input", REPO / "data" / "sam3d_objects")
    per_input: dict[str, Any] = {}
    for name, source in inputs.items():
        if args.only and args.only not in name:
            continue
        rules_rc, rules_s = _generate(source, args.out / f"{name}.rules", "rules", args.variants)
        cassette = args.out / f"{name}.cassette.json"
        cassette.unlink(missing_ok=True)
        rc, wall_s = _generate(source, args.out / f"{name}.model", f"record:{cassette}={args.model}", args.variants)
        entry: dict[str, Any] = {"exit": rc, "rules_exit": rules_rc, "wall_s": wall_s, "rules_wall_s": rules_s}
        if rc in (0, 1) and rules_rc in (0, 1):
            ours, base = _validity(args.out / f"{name}.model"), _validity(args.out / f"{name}.rules")
            report = ours.pop("report")
            detail = _structure(report)
            base.pop("report")
            account = report.get("model") or {}
            nav_ok = ours["nav"] is not None and base["nav"] is not None and ours["nav"] >= base["nav"] - 0.01
            entry.update(
                model=ours,
                rules=base,
                at_least_as_valid=(
                    ours["walls"] >= base["walls"]
                    and ours["shortest_wall_m"] >= min(0.3, base["shortest_wall_m"])
                    and ours["collisions"] <= base["collisions"]
                    and ours["out_of_bounds"] <= base["out_of_bounds"]
                    and ours["tipped_or_fell"] <= base["tipped_or_fell"]
                    and nav_ok
                ),
                within_5_min=wall_s <= 300,
                model_summary=account.get("summary"),
                given_up=account.get("given_up", []),
                deadline=account.get("deadline"),
                model_requests=sum(k.get("requests", 0) for k in account.get("kinds", {}).values()),
                requests=detail.get("usage", {}).get("requests"),
                agents={k: v["answered_by"] for k, v in detail.get("agents", {}).items()},
                repairs={k: v["repairs"] for k, v in detail.get("agents", {}).items() if v["repairs"]},
            )
        per_input[name] = entry
        print(json.dumps({name: entry}, sort_keys=True), flush=True)
    figures = {
        "inputs": len(per_input),
        "exit_0": sum(e["exit"] == 0 for e in per_input.values()),
        "at_least_as_valid": sum(bool(e.get("at_least_as_valid")) for e in per_input.values()),
        "within_5_min": sum(bool(e.get("within_5_min")) for e in per_input.values()),
        "model_wall_s_total": round(sum(e["wall_s"] for e in per_input.values()), 1),
        "model_wall_s_max": max((e["wall_s"] for e in per_input.values()), default=0.0),
        "per_input": per_input,
    }
    print(json.dumps(figures, sort_keys=True))
    return 0


if __name__ == "__main__":
    sys.exit(main())
