"""Command-line interface: ``scenemosaic generate | demo | inspect | schema``."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.progress import BarColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

from scenemosaic._logging import configure_logging
from scenemosaic.exceptions import SceneMosaicError
from scenemosaic.pipeline import STAGE_NAMES, GenerateConfig, GenerateResult, agenerate

__all__ = ["app", "main"]

app = typer.Typer(
    name="scenemosaic",
    help="Simulation-ready indoor scenes and diverse layout variants from one reference scene.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
_err = Console(stderr=True)
_out = Console()

def _log_level(value: str) -> str:
    try:
        configure_logging(value)
    except ValueError as exc:
        raise typer.BadParameter(str(exc)) from exc
    return value


LogLevelOpt = Annotated[
    str,
    typer.Option("--log-level", callback=_log_level, help="Log level: debug, info, warning, error. Logs go to stderr."),
]


def _run_with_progress(input_path: Path, out: Path, config: GenerateConfig) -> GenerateResult:
    with Progress(
        SpinnerColumn(),
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        TextColumn("{task.completed}/{task.total} stages"),
        TimeElapsedColumn(),
        console=_err,
        transient=False,
    ) as progress:
        task = progress.add_task("starting", total=len(STAGE_NAMES))

        def on_stage(name: str, status: str) -> None:
            if status == "started":
                progress.update(task, description=name)
            else:
                progress.advance(task)

        return asyncio.run(agenerate(input_path, out, config, on_stage=on_stage))


def _summarize(result: GenerateResult) -> None:
    report = result.report
    _out.print(f"[green]wrote[/green] {result.out_dir} ({report['objects']} objects, {report['total_seconds']:.1f} s)")
    for stage in report["stages"]:
        _out.print(f"  {stage['name']:<10} {stage['status']:<8} {stage['seconds']:7.2f} s")
    validation = report.get("validation") or {}
    if validation:
        figures = {
            "collision pairs": len(validation.get("collisions", {}).get("pairs", [])),
            "out of bounds": len(validation.get("out_of_bounds", {}).get("objects", [])),
            "tipped": len(validation.get("tipped", [])),
            "fell": len(validation.get("fell", [])),
        }
        _out.print("  validation: " + ", ".join(f"{k} {v}" for k, v in figures.items()))


@app.command()
def generate(
    input_path: Annotated[Path, typer.Argument(metavar="INPUT", help="Scene folder or file (layout JSON, house JSON, poses JSON).")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Output folder.")],
    format: Annotated[
        str, typer.Option("--format", help="auto, native, front3d, procthor, holodeck, sam3d, sceneeval.")
    ] = "auto",
    variants: Annotated[
        int, typer.Option("--variants", min=0, help="Number of diverse variants (m); not available yet: 0 only.")
    ] = 0,
    model: Annotated[str, typer.Option("--model", help="rules | openai:<model>[@<base_url>] | replay:<cassette.json>")] = "rules",
    seed: Annotated[int, typer.Option("--seed", help="Run seed.")] = 0,
    room: Annotated[
        str | None, typer.Option("--room", help="Room id for multi-room house files (e.g. 'room|3').")
    ] = None,
    asset_dir: Annotated[
        Path | None,
        typer.Option("--asset-dir", help="Folder of <assetId>.glb meshes for SceneEval inputs (default: assets/ beside it)."),
    ] = None,
    vision: Annotated[
        bool | None, typer.Option("--vision/--no-vision", help="Send images to the model (off for text-only servers).")
    ] = None,
    fallback: Annotated[
        bool,
        typer.Option(
            "--solver-fallback/--no-solver-fallback",
            help="Use an agent's rule solver when the model's answers stay unusable (default) or fail the run.",
        ),
    ] = True,
    priors: Annotated[
        Path | None,
        typer.Option("--priors", help="ProcTHOR priors folder replacing the priors shipped with the package."),
    ] = None,
    log_level: LogLevelOpt = "warning",
) -> None:
    """Turn INPUT into a stabilized, simulation-ready scene in the output layout under --out."""
    config = GenerateConfig(
        format=format,
        variants=variants,
        model=model,
        seed=seed,
        room=room,
        vision=vision,
        priors_dir=priors,
        solver_fallback=fallback,
        asset_dir=asset_dir,
    )
    try:
        result = _run_with_progress(input_path, out, config)
    except SceneMosaicError as exc:
        _err.print(f"[red]error:[/red] {exc}")
        _err.print(f"partial results and the report are in {out}")
        raise typer.Exit(code=2) from exc
    _summarize(result)


@app.command()
def demo(
    out: Annotated[Path, typer.Option("--out", "-o", help="Output folder.")] = Path("out/demo"),
    seed: Annotated[int, typer.Option("--seed", help="Run seed.")] = 0,
    log_level: LogLevelOpt = "warning",
) -> None:
    """Run generate on the bundled procedural demo scene, offline (rules model, no key, no network)."""
    from scenemosaic.exchange import save_scene
    from scenemosaic.pipeline import demo_scene

    source = out / "input"
    save_scene(demo_scene(), source)
    try:
        result = _run_with_progress(source, out, GenerateConfig(model="rules", seed=seed))
    except SceneMosaicError as exc:
        _err.print(f"[red]error:[/red] {exc}")
        raise typer.Exit(code=2) from exc
    _summarize(result)


@app.command()
def inspect(
    scene_path: Annotated[
        Path, typer.Argument(metavar="SCENE", help="A scene folder or scene.json, or any input generate reads.")
    ],
    as_json: Annotated[bool, typer.Option("--json", help="Print the units and constraints as JSON.")] = False,
    log_level: LogLevelOpt = "warning",
) -> None:
    """Show a scene's tree: anchors, their children, units and cross-unit constraints."""
    from scenemosaic.exchange import load_scene
    from scenemosaic.scene import format_tree

    try:
        scene = load_scene(scene_path)
    except SceneMosaicError as exc:
        _err.print(f"[red]error:[/red] {exc}")
        raise typer.Exit(code=2) from exc
    if as_json:
        payload = {
            "units": [u.model_dump(mode="json") for u in (scene.structure.units if scene.structure else [])],
            "constraints": [c.model_dump(mode="json") for c in scene.constraints],
        }
        _out.print_json(json.dumps(payload))
    else:
        _out.print(format_tree(scene), markup=False, highlight=False, soft_wrap=True)


@app.command()
def schema(
    out: Annotated[Path | None, typer.Option("--out", "-o", help="Write to this file instead of stdout.")] = None,
) -> None:
    """Print (or write) the JSON Schema of scene.json."""
    from scenemosaic.scene import Scene

    text = json.dumps(Scene.model_json_schema(), indent=2, sort_keys=True) + "\n"
    if out is None:
        typer.echo(text, nl=False)
    else:
        out.write_text(text, encoding="utf-8")


def main() -> None:
    """Console-script entry point."""
    app()


if __name__ == "__main__":
    main()
