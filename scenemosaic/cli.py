"""Command-line interface: ``scenemosaic generate | demo | inspect | evaluate | batch | export |
render | edit | schema``.

Errors are one line (the traceback of an unexpected one goes to ``report.json``); exit codes:
0 done, 1 unexpected error (or degraded under ``--strict``), 2 bad input or settings, 130 SIGINT,
143 SIGTERM.

The CLI starts light: a command imports what it uses in its body, so ``--help`` loads no part of
the library (no pipeline, no scene model) and ``inspect`` no MuJoCo, CoACD or trimesh;
``generate``'s options for the run's settings are made when that command is used or its help
shown (:class:`_SettingsCommand`). ``benchmarks/cli.py`` times them.
"""

from __future__ import annotations

import functools
import json
import os
import re
import signal
import sys
import threading
import time
from collections.abc import Callable
from enum import StrEnum
from inspect import Parameter, Signature, signature
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, NoReturn, TypeVar

import typer
from rich.console import Console
from rich.markup import escape as _escape_markup
from typer.core import TyperArgument, TyperCommand, TyperOption
from typer.models import CommandFunctionType

from scenemosaic.exceptions import SceneMosaicError

if TYPE_CHECKING:  # the commands import these in their bodies: the CLI starts without them
    import asyncio

    from scenemosaic.assets import OpenState
    from scenemosaic.batch import BatchSummary, JobRecord
    from scenemosaic.pipeline import GenerateConfig, GenerateResult
    from scenemosaic.scene import House, Scene

__all__ = ["app", "main"]


class _Command(TyperCommand):
    """A command whose help reads as click's does: no type label beside a flag (typer prints
    ``<bool>``) and no braces around a required argument in the usage line (``{SCENE}``)."""

    def get_params(self, ctx: Any) -> Any:
        params = super().get_params(ctx)
        for param in params:
            if isinstance(param, TyperOption) and param.is_flag and param.metavar is None:
                param.metavar = ""  # shown as the type column: empty for a flag
        return params

    def collect_usage_pieces(self, ctx: Any) -> list[str]:
        pieces = [self.options_metavar] if self.options_metavar else []
        for param in self.get_params(ctx):
            if not isinstance(param, TyperArgument):
                continue
            name = param.metavar or (param.name or "").upper()
            if param.nargs != 1 and not name.endswith("..."):
                name += "..."
            pieces.append(name if param.required or name.startswith("[") else f"[{name}]")
        return pieces


class _App(typer.Typer):
    """The CLI's Typer: every command is a :class:`_Command`."""

    def command(self, *args: Any, **kwargs: Any) -> Callable[[CommandFunctionType], CommandFunctionType]:
        kwargs.setdefault("cls", _Command)
        return super().command(*args, **kwargs)


app = _App(
    name="scenemosaic",
    help="Simulation-ready indoor scenes and diverse layout variants from one reference scene.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
_CONTROL_CHARS = re.compile(r"[\x00-\x08\x0b-\x1f\x7f]")


def escape(text: str) -> str:
    """Text for the console: Rich markup escaped, and control characters (a NUL byte read from an
    input file) shown as ``\\x00`` instead of being sent to the terminal raw."""
    return _escape_markup(_CONTROL_CHARS.sub(lambda m: f"\\x{ord(m.group()):02x}", text))


_err = Console(stderr=True, emoji=False, soft_wrap=True)  # "openai:m:" is a model name, not an emoji code; a long path is not broken
_out = Console(emoji=False)

REPORTED_EVENTS = ("run_degraded", "stage_failed", "stage_interrupted")
"""Log events the CLI reports itself (the degraded summary, the error line, the interrupted line):
left out of its log so that nothing is printed twice."""
_log_settings = {"level": "warning", "log_format": "text"}


def _configure_logging(key: str, value: str) -> str:
    from scenemosaic._logging import configure_logging  # structlog: loaded by a command, not by --help

    try:
        settings = {**_log_settings, key: value}
        configure_logging(settings["level"], log_format=settings["log_format"], suppress=REPORTED_EVENTS)
    except ValueError as exc:
        raise typer.BadParameter(str(exc)) from exc
    _log_settings[key] = value
    return value


def _flush_logs() -> None:
    """Write the warnings the log still holds folded (``scenemosaic._logging.flush_logs``)."""
    from scenemosaic._logging import flush_logs

    flush_logs()


LogLevelOpt = Annotated[
    str,
    typer.Option(
        "--log-level",
        callback=lambda value: _configure_logging("level", value),
        help="Log level: debug, info, warning, error. Logs go to stderr.",
    ),
]
LogFormatOpt = Annotated[
    str,
    typer.Option(
        "--log-format",
        envvar="SCENEMOSAIC_LOG_FORMAT",
        callback=lambda value: _configure_logging("log_format", value),
        help="Log lines: text (readable, repeated warnings folded into one line) or json (one object a line).",
    ),
]


EXIT_OK = 0
EXIT_UNEXPECTED = 1
"""An unexpected error (a bug), or a degraded result under ``--strict``."""
EXIT_BAD_INPUT = 2
"""A clear error about the input or the settings (a ``SceneMosaicError``)."""
EXIT_SIGINT = 130
EXIT_SIGTERM = 143
REPORT_WAIT_S = 5.0
"""Longest a second signal waits for the first one's report before exiting."""


class _Stop:
    """Turns SIGINT/SIGTERM into a cancel of the running task; a second signal exits at once.

    The pipeline writes ``report.json`` first thing when cancelled. A second signal that comes
    before it is on disk (two signals back to back) waits for it, at most
    :data:`REPORT_WAIT_S`, then exits: the report is not lost. Worker threads and CoACD processes
    are not waited for. A signal that comes before the run's loop is up (:meth:`hold`: while the
    pipeline's modules load) is kept and stops the run as soon as it starts, instead of raising
    ``KeyboardInterrupt`` inside an import, where a library may swallow it (the run then went on
    to the end) — or, for SIGTERM, killing the process before it writes anything.
    """

    def __init__(self, report: Path | None = None) -> None:
        self.signal: int | None = None
        self.task: asyncio.Task[GenerateResult] | None = None
        self.report = report
        self.started = time.time()
        self.loop: asyncio.AbstractEventLoop | None = None
        self.on_stop: Callable[[str], None] | None = None
        """Shows that the run is stopping (the progress bar's label); no line is printed, so an
        interrupted run ends with one line."""
        self.pending: int | None = None
        """A signal received before :meth:`install`."""
        self._previous: dict[int, Any] = {}

    def hold(self) -> None:
        """Keep SIGINT and SIGTERM until :meth:`install` (main thread only; :meth:`release` undoes it)."""
        if threading.current_thread() is not threading.main_thread():
            return
        for sig in (signal.SIGINT, signal.SIGTERM):
            self._previous[sig] = signal.signal(sig, self._early)

    def release(self) -> None:
        """The signal handlers as they were before :meth:`hold`."""
        for sig, previous in self._previous.items():
            signal.signal(sig, previous)
        self._previous.clear()

    def _early(self, sig: int, frame: object) -> None:
        if self.pending is not None:  # a second one: nothing has started, leave at once
            sys.stderr.flush()
            os._exit(_exit_code(self.pending))
        self.pending = sig

    def install(self, loop: asyncio.AbstractEventLoop) -> None:
        self.loop = loop
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, self._received, sig)
        if self.pending is not None:
            loop.call_soon(self._received, self.pending)

    def _reported(self) -> bool:
        try:
            return self.report is None or self.report.stat().st_mtime >= self.started - 1.0
        except OSError:
            return False

    def wrote_report(self) -> bool:
        """Whether this run wrote its report (one stopped as it started wrote none)."""
        return self._reported()

    def _exit_when_reported(self, deadline: float) -> None:
        if self._reported() or time.monotonic() >= deadline or self.loop is None:
            _hard_exit(_exit_code(self.signal))
        self.loop.call_later(0.05, self._exit_when_reported, deadline)

    def _received(self, sig: int) -> None:
        if self.signal is not None:  # second signal: leave as soon as the report is on disk
            _err.print("[red]stopped[/red] (second signal)")
            self._exit_when_reported(time.monotonic() + REPORT_WAIT_S)
            return
        self.signal = sig
        if self.on_stop is not None:
            self.on_stop(signal.Signals(sig).name)
        if self.task is not None:
            self.task.cancel()


def _exit_code(sig: int | None) -> int:
    return EXIT_SIGTERM if sig == signal.SIGTERM else EXIT_SIGINT


def _hard_exit(code: int) -> NoReturn:
    """Leave now: stop the CoACD workers, flush, and skip waiting for worker threads."""
    from scenemosaic.assets import shutdown_workers

    try:
        shutdown_workers()
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)


def _run_with_progress(input_path: Path | None, out: Path, config: GenerateConfig) -> GenerateResult:
    from scenemosaic.scene import RunFolder

    stop = _Stop(RunFolder(out).report)
    stop.hold()
    try:
        return _run_held(input_path, out, config, stop)
    finally:
        stop.release()


def _run_held(input_path: Path | None, out: Path, config: GenerateConfig, stop: _Stop) -> GenerateResult:
    import asyncio

    from rich.progress import BarColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    from scenemosaic import pipeline  # its stages load on first use, after the signals are held

    with Progress(
        SpinnerColumn(),
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        TextColumn("{task.completed}/{task.total} stages"),
        TimeElapsedColumn(),
        console=_err,
        transient=False,
    ) as progress:
        bar = progress.add_task("starting", total=None)
        stop.on_stop = lambda name: progress.update(bar, description=f"stopping ({name}): writing the report")
        planned: list[str] = []

        def on_stage(name: str, status: str) -> None:
            if status == "planned":  # the run's plan, announced before its first stage
                planned.append(name)
                progress.update(bar, total=len(planned))
                return
            if status == "started":
                progress.update(bar, description=name)
            else:
                _flush_logs()  # the stage's folded warnings, before the next stage's
                progress.advance(bar)

        async def main() -> GenerateResult:
            stop.install(asyncio.get_running_loop())
            stop.task = asyncio.current_task()  # type: ignore[assignment]
            try:
                return await pipeline.agenerate(input_path, out, config, on_stage=on_stage)
            except asyncio.CancelledError:
                if stop.signal is None:
                    raise
                # the report and the partial result are on disk: leave now, not after the stage's
                # worker thread (a long compose or export) ends, which asyncio.run would wait for
                progress.stop()
                _interrupted(out, stop.signal, stop.wrote_report())

        try:
            return asyncio.run(main())
        except asyncio.CancelledError:
            if stop.signal is None:
                raise
        finally:
            _flush_logs()
    _interrupted(out, stop.signal, stop.wrote_report())


def _interrupted(out: Path, sig: int | None, reported: bool = True) -> NoReturn:
    """The one line of a run stopped by a signal, then the exit (130 or 143)."""
    from scenemosaic.scene import RunFolder

    _flush_logs()
    if not reported:  # stopped before the run wrote anything (a signal as it started)
        _err.print("[yellow]interrupted[/yellow] before the run started: nothing written")
        _hard_exit(_exit_code(sig))
    kept = "report and partial result" if (RunFolder(out).base / RunFolder.PARTIAL).exists() else "report"
    _err.print(f"[yellow]interrupted[/yellow]: {kept} in {escape(str(out))}; continue with --resume {escape(str(out))}")
    _hard_exit(_exit_code(sig))


def _failed_stage(out: Path) -> str | None:
    from scenemosaic.scene import RunFolder

    try:
        value = json.loads(RunFolder(out).report.read_text(encoding="utf-8")).get("failed_stage")
    except (OSError, ValueError, AttributeError):
        return None
    return value if isinstance(value, str) else None


def _file_state(path: Path) -> tuple[int, int] | None:
    """``(mtime_ns, size)`` of a file, ``None`` when there is none: tells a report this run wrote
    from an earlier run's."""
    try:
        stat = path.stat()
    except OSError:
        return None
    return stat.st_mtime_ns, stat.st_size


def _run_cli(input_path: Path | None, out: Path, config: GenerateConfig) -> None:
    """Run, then map the outcome to an exit code: errors are one line, never a traceback."""
    from scenemosaic.scene import RunFolder

    earlier_report = _file_state(RunFolder(out).report)
    try:
        result = _run_with_progress(input_path, out, config)
    except SceneMosaicError as exc:
        _err.print(f"[red]error:[/red] {escape(str(exc))}", highlight=False)
        report = _file_state(RunFolder(out).report)
        if report is not None and report != earlier_report:  # not an earlier run's (a refused overwrite)
            kept = "the partial result and the report are" if (RunFolder(out).base / RunFolder.PARTIAL).exists() else "the report is"
            _err.print(f"{kept} in {out}", markup=False, highlight=False)
        raise typer.Exit(code=EXIT_BAD_INPUT) from exc
    except Exception as exc:  # a bug: one line here, the traceback in the report
        stage = _failed_stage(out)
        where = f" in stage {stage!r}" if stage else ""
        _err.print(
            "[red]error:[/red] "
            + escape(f"unexpected {type(exc).__name__}{where} on {input_path}: {exc} (traceback in {RunFolder(out).report})"),
            highlight=False,
        )
        raise typer.Exit(code=EXIT_UNEXPECTED) from exc
    _summarize(result)
    for line in result.run_report.notes:
        _err.print(f"[cyan]note:[/cyan] {escape(line)}", highlight=False)
    if result.status == "degraded":
        _err.print("[yellow]warning:[/yellow] the result is degraded (status 'degraded' in report.json):")
        for line in result.run_report.warnings[:10]:
            _err.print(f"  - {line}", markup=False, highlight=False)
        if config.strict:
            raise typer.Exit(code=EXIT_UNEXPECTED)


def _summarize(result: GenerateResult) -> None:
    report = result.run_report
    _out.print(f"[green]wrote[/green] {escape(str(result.out_dir))} ({report.objects} objects, {report.total_seconds:.1f} s)")
    for stage in report.stages:
        _out.print(f"  {stage.name:<10} {stage.status:<8} {stage.seconds:7.2f} s", markup=False)
    figures = report.figures()
    if figures:
        label = "house" if report.is_house else "validation"
        _out.print(f"  {label}: " + ", ".join(f"{k} {v}" for k, v in figures.items()), highlight=False)
    if report.model is not None:
        _out.print(f"  model: {report.model['summary']}", markup=False, highlight=False)



_PANELS: dict[str, str] = {
    "input": "Input",
    "perception": "Perception (a photograph or a text prompt)",
    "model": "Model",
    "evolution": "Evolution",
    "limits": "Limits",
    "run": "Run",
}
"""generate's help panel of each group of settings (``Setting.group``)."""


class _SettingsCommand(_Command):
    """A command that takes the run's settings (``generate``): its option for each setting
    (:func:`_with_setting_options`) is made the first time its parameters are asked for, to parse
    its arguments or to show its help, not when the CLI starts. The options come from the
    pipeline's settings, which import pydantic and the scene model; ``scenemosaic --help`` and
    the other commands need none of it (the top-level help lists this command by its help text).

    The command is registered with the parameters its function declares (``**settings`` left
    out); once loaded, its parameters and callback are those of the command typer builds from the
    function with every setting's option added.
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self._with_settings = False
        super().__init__(*args, **kwargs)

    @property
    def params(self) -> list[Any]:
        if not self._with_settings:
            registered = self.callback
            assert registered is not None, "typer registers a command with its function"
            function = getattr(registered, "__wrapped__", registered)  # typer's wrapper keeps the function
            one = _App(add_completion=False, pretty_exceptions_enable=False)
            one.command(name=self.name)(_with_setting_options(function))
            built = typer.main.get_command(one)
            self._params, self.callback = built.params, built.callback
            self._with_settings = True
        return self._params

    @params.setter
    def params(self, value: list[Any]) -> None:
        self._params = value


def _declared_params(command: CommandFunctionType) -> CommandFunctionType:
    """``command`` shown to typer without its ``**settings``: what :class:`_SettingsCommand`
    registers before the settings' options are made."""
    params = [p for p in signature(command, eval_str=True).parameters.values() if p.kind is not Parameter.VAR_KEYWORD]
    command.__signature__ = Signature(params, return_annotation=None)  # type: ignore[attr-defined]
    return command


def _with_setting_options(command: Callable[..., Any]) -> Callable[..., Any]:
    """``command`` (a copy) with an option for every setting that has a flag, built from
    GenerateConfig's fields (``setting_options``: flag, default, choices, help and bounds), so that
    none is restated here; each reaches ``**settings`` under its field's name. ``--resume`` takes
    the stopped run's output folder (the setting itself is on or off)."""
    from scenemosaic import pipeline

    @functools.wraps(command)
    def with_settings(**kwargs: Any) -> Any:
        return command(**kwargs)

    params = [p for p in signature(command, eval_str=True).parameters.values() if p.kind is not Parameter.VAR_KEYWORD]
    for option in pipeline.setting_options():
        kind: Any = Path if option.field == "resume" else option.kind
        default = None if option.field == "resume" else option.default
        info = typer.Option(
            option.decls,
            help=escape(option.help),
            rich_help_panel=_PANELS[option.group],
            metavar="[" + "|".join(option.choices) + "]" if option.choices else None,  # checked with the rest
        )
        annotation = Annotated[kind if default is not None else kind | None, info]  # type: ignore[valid-type]
        params.append(Parameter(option.field, Parameter.KEYWORD_ONLY, default=default, annotation=annotation))
    with_settings.__signature__ = Signature(params, return_annotation=None)  # type: ignore[attr-defined]
    return with_settings


@app.command(cls=_SettingsCommand)
@_declared_params
def generate(
    input_path: Annotated[
        Path | None,
        typer.Argument(
            metavar="[INPUT]",
            help="Scene folder or file (layout JSON, house JSON, poses JSON, sceneState), or a photograph (.png, .jpg).",
        ),
    ] = None,
    out: Annotated[Path | None, typer.Option("--out", "-o", help="Output folder.")] = None,
    log_level: LogLevelOpt = "warning",
    log_format: LogFormatOpt = "text",
    **settings: Any,
) -> None:
    """Turn INPUT into a stabilized, simulation-ready scene in the output layout under --out.

    Exit codes: 0 done (also when degraded, unless --strict), 1 unexpected error or degraded
    under --strict, 2 bad input or settings, 130 stopped by Ctrl-C, 143 stopped by SIGTERM.
    """
    from scenemosaic.pipeline import GenerateConfig, SettingsError, checkpoint_config

    resume: Path | None = settings.pop("resume")
    if resume is not None:
        try:
            input_path, config = checkpoint_config(resume)
        except SceneMosaicError as exc:
            _err.print(f"[red]error:[/red] {escape(str(exc))}", highlight=False)
            raise typer.Exit(code=EXIT_BAD_INPUT) from exc
        _run_cli(input_path, resume, config.model_copy(update={"restart_stale": settings["restart_stale"]}))
        return
    if (input_path is None) == (settings["prompt"] is None) or out is None:
        _err.print(
            "[red]error:[/red] give INPUT or --prompt TEXT (one of them), and --out (or --resume OUT to continue a stopped run)"
        )
        raise typer.Exit(code=EXIT_BAD_INPUT)
    try:
        config = GenerateConfig(**settings)
    except SettingsError as exc:  # named by their flags: one line each
        for line in exc.describe(_flag_of):
            _err.print(f"[red]error:[/red] {escape(line)}", highlight=False)
        raise typer.Exit(code=EXIT_BAD_INPUT) from exc
    _run_cli(input_path, out, config)


def _flag_of(field: str) -> str:
    """A setting's ``generate`` flag (``evolve_rounds`` -> ``--rounds``), else its name."""
    from scenemosaic.pipeline import SETTINGS

    setting = SETTINGS.get(field)
    return setting.flag if setting is not None and setting.flag else repr(field)


@app.command()
def demo(
    out: Annotated[Path, typer.Option("--out", "-o", help="Output folder.")] = Path("out/demo"),
    seed: Annotated[int, typer.Option("--seed", help="Run seed.")] = 0,
    log_level: LogLevelOpt = "warning",
    log_format: LogFormatOpt = "text",
) -> None:
    """Run generate on the bundled procedural demo scene, offline (rules model, no key, no network)."""
    from scenemosaic.exchange import save_scene
    from scenemosaic.pipeline import GenerateConfig, demo_scene

    _writable_folder(out)
    source = out / "input"
    save_scene(demo_scene(), source)
    _run_cli(source, out, GenerateConfig(model="rules", seed=seed, overwrite=True))


@app.command()
def inspect(
    scene_path: Annotated[
        Path,
        typer.Argument(
            metavar="SCENE", help="A generate output folder (its base/), a scene folder or scene.json, or any input generate reads."
        ),
    ],
    as_json: Annotated[bool, typer.Option("--json", help="Print the units and constraints as JSON.")] = False,
    variant: VariantOpt = None,
    room: RoomOpt = None,
    allow_partial: AllowPartialOpt = False,
    log_level: LogLevelOpt = "warning",
) -> None:
    """Show a scene's tree: anchors, their children, units and cross-unit constraints (a house:
    its rooms and the doors between them; --room for one room's tree)."""
    from scenemosaic.scene import House, format_tree

    loaded, _ = _load_any(scene_path, variant, room, allow_partial)
    if isinstance(loaded, House):
        _print_house(loaded, as_json)
        return
    scene = loaded
    if as_json:
        payload = {
            "units": [u.model_dump(mode="json") for u in (scene.structure.units if scene.structure else [])],
            "constraints": [c.model_dump(mode="json") for c in scene.constraints],
        }
        _out.print_json(json.dumps(payload))
    else:
        _out.print(format_tree(scene), markup=False, highlight=False, soft_wrap=True)


def _print_house(house: House, as_json: bool) -> None:
    rooms: list[dict[str, Any]] = [
        {"id": r.id, "type": r.provenance.room_type, "objects": len(r.objects)} for r in house.rooms
    ]
    doors: list[dict[str, Any]] = [{"id": d.id, "kind": d.kind, "rooms": list(d.rooms), "width_m": round(d.width, 3)} for d in house.doorways()]
    if as_json:
        _out.print_json(json.dumps({"house": house.id, "rooms": rooms, "doorways": doors}))
        return
    _out.print(f"house {house.id}: {len(rooms)} rooms, {len(house.objects)} objects", markup=False, highlight=False)
    for r in rooms:
        _out.print(f"  {r['id']:<12} {r['type'] or '':<12} {r['objects']:>4} objects", markup=False, highlight=False)
    for d in doors:
        joins = " <-> ".join(d["rooms"]) if len(d["rooms"]) > 1 else f"{d['rooms'][0]} <-> outside"
        _out.print(f"  {d['kind']:<8} {joins} ({d['width_m']:.2f} m)", markup=False, highlight=False)


@app.command()
def evaluate(
    path: Annotated[
        Path,
        typer.Argument(metavar="DIR_OR_SCENE", help="A generate output folder (base/ and variant_*/), or one scene or house."),
    ],
    room: RoomOpt = None,
    allow_partial: AllowPartialOpt = False,
    log_level: LogLevelOpt = "warning",
) -> None:
    """Print the scene metrics as JSON: COL, OOB, NAV of the base and each variant, RelKeep,
    Div-IoU and Div-N over the variants (see docs/composition.md).

    A house run gives every room's metrics and the house's (house NAV, unreachable rooms, blocked
    doors, objects across walls, RelKeep, house diversity; docs/houses.md); --room gives one
    room's metrics over the base and the variants.
    """
    from scenemosaic.metrics import evaluate
    from scenemosaic.metrics import evaluate as evaluate_scenes
    from scenemosaic.scene import House, Scene

    (_, base, folder), *rest = _load_scenes(path, room, allow_partial)
    dirs = [f for _, _, f in rest]
    result: dict[str, Any]
    if isinstance(base, House):
        result = evaluate(base, _all_of(House, rest), base_dir=folder, variant_dirs=dirs)
    else:
        result = evaluate_scenes(base, _all_of(Scene, rest), base_dir=folder, variant_dirs=dirs)
    _out.print_json(json.dumps(result))


class BatchExecutor(StrEnum):
    """Where ``scenemosaic batch`` runs its jobs."""

    local = "local"
    ray = "ray"


_STATUS_STYLE = {
    "ok": "green",
    "degraded": "yellow",
    "skipped": "cyan",
    "failed": "red",
    "timeout": "red",
    "pending": "dim",
    "running": "blue",
}


class _Terminated(Exception):
    """SIGTERM reached ``scenemosaic batch``: unwinds it so the running workers are stopped."""


def _raise_terminated(signum: int, frame: object) -> None:
    raise _Terminated


def _print_batch_summary(summary: BatchSummary) -> None:
    from rich.table import Table

    from scenemosaic.batch import SUMMARY_FILE

    table = Table(title=f"batch {escape(str(summary.out))}", title_justify="left")
    table.add_column("job")
    table.add_column("status")
    table.add_column("seconds", justify="right")
    table.add_column("variants", justify="right")
    table.add_column("error", overflow="fold")
    for job in summary.jobs:
        style = _STATUS_STYLE.get(job.status, "")
        table.add_row(
            escape(job.id),
            f"[{style}]{job.status}[/{style}]" if style else job.status,
            f"{job.wall_s:.1f}",
            str(job.variants_written),
            escape(job.error or ""),
        )
    _out.print(table)
    counts = ", ".join(f"{n} {status}" for status, n in summary.counts.items())
    _out.print(
        f"{counts}; {summary.scenes_written} scenes in {summary.wall_s:.1f} s; "
        f"summary in {Path(summary.out) / SUMMARY_FILE}",
        markup=False,
        highlight=False,
    )


@app.command()
def batch(
    manifest: Annotated[
        Path,
        typer.Argument(
            metavar="MANIFEST",
            help='JSONL file, one job a line: {"input": "room.json", "variants": 5, "seed": 0, "id": "name", ...}.',
        ),
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="Output folder; each job writes OUT/<id>/.")],
    executor: Annotated[
        BatchExecutor, typer.Option("--executor", help="local: worker processes on this machine; ray: Ray tasks.")
    ] = BatchExecutor.local,
    workers: Annotated[int, typer.Option("--workers", min=1, help="Jobs running at once.")] = 1,
    timeout: Annotated[
        float | None,
        typer.Option("--timeout", min=0.001, help="Seconds one job may run; then it is stopped and recorded as timeout."),
    ] = None,
    index: Annotated[
        str | None,
        typer.Option(
            "--index",
            metavar="A:B",
            help="With a dataset of houses as MANIFEST: the houses A to B-1 only (N: house N; A: from A on).",
        ),
    ] = None,
    log_level: LogLevelOpt = "warning",
) -> None:
    """Run every job of MANIFEST (see docs/batch.md); jobs already finished in OUT are skipped.
    MANIFEST may be a dataset of houses (.jsonl or .jsonl.gz, one house a line): one job a house,
    each in OUT/<file stem>-<index>.

    Exit codes: 0 every job ok, degraded or skipped, 1 a job failed or timed out, 2 bad manifest
    or settings, 130 stopped by Ctrl-C, 143 stopped by SIGTERM (finished jobs stay recorded in
    OUT/batch_summary.json; run again to do the rest).
    """
    from rich.progress import BarColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    from scenemosaic.batch import SUMMARY_FILE, load_manifest, run_batch

    houses = _index_range(index)
    in_main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _raise_terminated) if in_main_thread else None
    try:
        total = len(load_manifest(manifest, houses))  # a bad line is reported before the progress bar starts
        with Progress(
            SpinnerColumn(),
            TextColumn("[bold]{task.description}"),
            BarColumn(),
            TextColumn("{task.completed}/{task.total} jobs"),
            TimeElapsedColumn(),
            console=_err,
            transient=False,
        ) as progress:
            bar = progress.add_task("starting", total=total)
            running: list[str] = []

            def on_progress(record: JobRecord) -> None:
                if record.status == "running":
                    running.append(record.id)
                elif record.status != "pending":
                    if record.id in running:
                        running.remove(record.id)
                    progress.advance(bar)
                    if record.status in ("failed", "timeout"):
                        progress.console.print(f"[red]{record.status}[/red] {escape(record.id)}: {escape(record.error or '')}")
                progress.update(bar, description=", ".join(running) or "finishing")

            summary = run_batch(
                manifest,
                out,
                executor=executor.value,
                workers=workers,
                timeout_s=timeout,
                on_progress=on_progress,
                log_level=log_level,
                index=houses,
            )
    except SceneMosaicError as exc:
        _err.print(f"[red]error:[/red] {escape(str(exc))}", highlight=False)
        raise typer.Exit(code=EXIT_BAD_INPUT) from exc
    except KeyboardInterrupt as exc:
        _err.print(f"[yellow]interrupted[/yellow]: finished jobs are recorded in {escape(str(out / SUMMARY_FILE))}; run again to do the rest")
        raise typer.Exit(code=EXIT_SIGINT) from exc
    except _Terminated as exc:
        _err.print(f"[yellow]stopped[/yellow] (SIGTERM): finished jobs are recorded in {escape(str(out / SUMMARY_FILE))}")
        raise typer.Exit(code=EXIT_SIGTERM) from exc
    finally:
        if in_main_thread:
            signal.signal(signal.SIGTERM, previous)
    _print_batch_summary(summary)
    if not summary.ok:
        raise typer.Exit(code=EXIT_UNEXPECTED)


def _index_range(text: str | None) -> slice | None:
    """``--index`` of ``batch``: ``A:B`` (B excluded), ``A:`` or ``N``; anything else exits 2."""
    if text is None:
        return None
    first, colon, last = text.partition(":")
    try:
        start = int(first) if first.strip() else 0
        stop = (int(last) if last.strip() else None) if colon else start + 1
    except ValueError:
        start, stop = -1, None
    if start < 0 or (stop is not None and stop <= start):
        _err.print(f"[red]error:[/red] --index {escape(text)}: give A:B (houses A to B-1), A: or N, counting from 0")
        raise typer.Exit(code=EXIT_BAD_INPUT)
    return slice(start, stop)


def _scene_folders(path: Path) -> list[tuple[str, Path]]:
    """``[(name, folder)]``: a generate output folder's ``base`` and ``variant_<i>`` (in order),
    or the one scene ``path`` names (a folder or a file, named by its folder)."""
    from scenemosaic.scene import RunFolder

    if RunFolder.is_run(path):
        return RunFolder(path).scenes()
    return [(path.stem if path.is_file() else path.name, path)]


def _run_seed(folder: Path) -> int:
    """The seed of the generate run ``folder`` is (or is a scene folder of): its ``report.json``'s
    ``config.seed``; 0 outside a run or when the report does not say."""
    from scenemosaic.scene import RunFolder

    for root in (folder, folder.parent):
        if RunFolder.is_run(root) and RunFolder(root).report.is_file():
            try:
                seed = json.loads(RunFolder(root).report.read_text(encoding="utf-8")).get("config", {}).get("seed")
            except (OSError, ValueError, AttributeError):
                return 0
            return seed if isinstance(seed, int) and not isinstance(seed, bool) else 0
    return 0


def _load_any(
    path: Path, variant: str | None = None, room: str | None = None, allow_partial: bool = False
) -> tuple[Scene | House, Path]:
    """The scene or house ``path`` names (a generate output folder gives its base, or ``variant``;
    a house gives ``room`` when one is named) and the folder its mesh paths start from. The
    partial result of a failed or stopped run is refused unless ``allow_partial``."""
    from scenemosaic.exchange import load_scene
    from scenemosaic.scene import RunFolder

    try:
        if RunFolder.is_run(path):
            path = RunFolder(path).scene_folder(variant)
        elif variant is not None:
            raise SceneMosaicError(f"--variant needs a generate output folder; {path} is not one")
        return load_scene(path, room=room, allow_partial=allow_partial), path if path.is_dir() else path.parent
    except SceneMosaicError as exc:
        _err.print(f"[red]error:[/red] {escape(str(exc))}")
        raise typer.Exit(code=EXIT_BAD_INPUT) from exc


def _writable_folder(folder: Path) -> None:
    """Make the output folder ``folder`` and show that it takes a file; one that cannot be made
    or written (under a file, read-only, no permission) is the user's to fix: one line, exit 2."""
    import tempfile

    problem = "it exists and is not a folder" if folder.exists() and not folder.is_dir() else None
    if problem is None:
        try:
            folder.mkdir(parents=True, exist_ok=True)
            with tempfile.TemporaryFile(dir=folder):
                pass
        except OSError as exc:
            problem = exc.strerror or str(exc)
    if problem is not None:
        _err.print(f"[red]error:[/red] cannot write the output folder {escape(str(folder))}: {escape(problem)}", highlight=False)
        raise typer.Exit(code=EXIT_BAD_INPUT)


def _write_failed(exc: OSError) -> NoReturn:
    """A write refused by the system after the folder checks (a folder where a file goes): one line, exit 2."""
    where = f": {exc.filename}" if exc.filename else ""
    _err.print(f"[red]error:[/red] cannot write{escape(where)} ({escape(exc.strerror or str(exc))})", highlight=False)
    raise typer.Exit(code=EXIT_BAD_INPUT) from exc


def _load_or_exit(
    path: Path, variant: str | None = None, room: str | None = None, allow_partial: bool = False
) -> tuple[Scene, Path]:
    """Like :func:`_load_any`, for a command that works on one room: a house needs ``--room``."""
    from scenemosaic.scene import House

    scene, folder = _load_any(path, variant, room, allow_partial)
    if isinstance(scene, House):
        _err.print(f"[red]error:[/red] {escape(str(path))} is a house; pick a room with --room ({', '.join(scene.room_ids)})")
        raise typer.Exit(code=EXIT_BAD_INPUT)
    return scene, folder


def _room_or_exit(house: House, room: str | None, path: Path) -> Scene:
    """The room ``room`` of ``house``; none named, or one the house lacks, exits 2 naming its rooms."""
    try:
        if room is not None:
            return house.room(room)
    except KeyError:
        pass
    what = "has no room " + repr(room) if room is not None else "is a house; pick a room with --room"
    _err.print(f"[red]error:[/red] {escape(str(path))} {escape(what)} ({', '.join(house.room_ids)})")
    raise typer.Exit(code=EXIT_BAD_INPUT)


_Loaded = TypeVar("_Loaded", "Scene", "House")


def _load_scenes(path: Path, room: str | None = None, allow_partial: bool = False) -> list[tuple[str, Scene | House, Path]]:
    """``[(name, scene or house, folder)]`` for every scene of ``path`` (:func:`_scene_folders`),
    each as :func:`_load_any` reads it: a house whole, or its room ``room``."""
    return [(name, *_load_any(folder, room=room, allow_partial=allow_partial)) for name, folder in _scene_folders(path)]


def _all_of(kind: type[_Loaded], loaded: list[tuple[str, Scene | House, Path]]) -> list[_Loaded]:
    """The scenes of ``loaded``, each a ``kind`` (a run whose base is a house has house variants)."""
    from scenemosaic.scene import House

    out = [s for _, s, _ in loaded if isinstance(s, kind)]
    if len(out) != len(loaded):
        odd = ", ".join(name for name, s, _ in loaded if not isinstance(s, kind))
        _err.print(f"[red]error:[/red] {escape(odd)}: not a {'house' if kind is House else 'room'} like the base")
        raise typer.Exit(code=EXIT_BAD_INPUT)
    return out


VariantOpt = Annotated[
    str | None,
    typer.Option("--variant", help="With a generate output folder: the variant to use (2 or variant_2) instead of base/."),
]
AllowPartialOpt = Annotated[
    bool,
    typer.Option(
        "--allow-partial",
        help="Read what a failed or stopped run kept in base/ (marked partial.json) as if it were delivered.",
    ),
]
RoomOpt = Annotated[
    str | None,
    typer.Option("--room", help="With a house (a house file or a house run): the room to use (room_4, or its source id room|4)."),
]


class OpenStateChoice(StrEnum):
    """The pose ``scenemosaic export --open-state`` delivers drawers, doors and lids in."""

    closed = "closed"
    open = "open"
    random = "random"


@app.command()
def export(
    path: Annotated[Path, typer.Argument(metavar="SCENE", help="A scene folder or file, or a generate output folder (base/ and every variant_*/).")],
    fmt: Annotated[str, typer.Option("--format", "-f", help="mjcf, usd, urdf, glb, sceneeval, native, procthor (any registered writer).")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Output folder; a generate output folder gets one sub-folder per scene.")],
    room: RoomOpt = None,
    allow_partial: AllowPartialOpt = False,
    open_state: Annotated[
        OpenStateChoice | None,
        typer.Option(
            "--open-state",
            help="Deliver drawers, doors and lids closed, open or at random (drawn from --seed); default: as the scene has them (the rooms' doors open unless closed).",
        ),
    ] = None,
    seed: Annotated[
        int | None,
        typer.Option("--seed", help="Seed of --open-state random; default: the generate run's seed (0 for a scene outside a run)."),
    ] = None,
    log_level: LogLevelOpt = "warning",
) -> None:
    """Write a saved scene (or every scene of a generate run) in another format: a house whole,
    as one world (--room: that room only)."""
    from scenemosaic.exchange import delivered_formats, writable_formats, write_scene
    from scenemosaic.scene import House, RunFolder

    writers = sorted({*writable_formats(), *writable_formats(house=True)})
    if fmt not in writers:
        _err.print(f"[red]error:[/red] unknown output format {escape(repr(fmt))}; use one of {', '.join(writers)}")
        raise typer.Exit(code=EXIT_BAD_INPUT)
    single = not RunFolder.is_run(path)
    for name, folder in _scene_folders(path):
        scene, base_dir = _load_any(folder, room=room, allow_partial=allow_partial)
        if open_state is not None:
            from scenemosaic.assets import open_scene

            state: OpenState = open_state.value
            drawn = seed if seed is not None else _run_seed(folder)
            if isinstance(scene, House):
                scene = open_scene(scene, state, drawn, base_dir)
            else:
                scene = open_scene(scene, state, drawn, base_dir)
        target = out if single else out / name
        _writable_folder(target)
        destination = target / dict(delivered_formats()).get(fmt, "")  # where generate puts it
        try:
            written = write_scene(scene, fmt, destination, base_dir)
        except SceneMosaicError as exc:
            _err.print(f"[red]error:[/red] {escape(str(exc))}")
            raise typer.Exit(code=EXIT_BAD_INPUT) from exc
        except OSError as exc:
            _write_failed(exc)
        _out.print(f"{name}: {written}", markup=False, highlight=False)


@app.command()
def render(
    path: Annotated[Path, typer.Argument(metavar="SCENE", help="A generate output folder (its base/), a scene folder or file.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="PNG file to write.")],
    unit: Annotated[
        str | None, typer.Option("--unit", help="Draw this unit's orthographic view (an anchor id: floor, a wall, a table...) instead of the floor plan.")
    ] = None,
    size: Annotated[int, typer.Option("--size", min=64, max=4096, help="Image side in pixels.")] = 1024,
    gl: Annotated[bool, typer.Option("--gl/--no-gl", help="Render the meshes with MuJoCo (MUJOCO_GL=egl) when a GL context can be made.")] = False,
    variant: VariantOpt = None,
    room: RoomOpt = None,
    allow_partial: AllowPartialOpt = False,
    log_level: LogLevelOpt = "warning",
) -> None:
    """Draw a scene's floor plan (a house's whole plan), or one local unit's orthographic view as
    the critic sees it, as PNG."""
    from scenemosaic.render import render_house_plan, render_topdown, render_view, topdown_view
    from scenemosaic.scene import House, write_atomic

    loaded, base_dir = _load_any(path, variant, room, allow_partial)
    if out.is_dir():
        _err.print(f"[red]error:[/red] --out {escape(str(out))} is a folder; give the PNG file to write", highlight=False)
        raise typer.Exit(code=EXIT_BAD_INPUT)
    if isinstance(loaded, House):
        if unit is not None:
            _err.print(f"[red]error:[/red] --unit needs one room: add --room ({escape(', '.join(loaded.room_ids))})")
            raise typer.Exit(code=EXIT_BAD_INPUT)
        _writable_folder(out.parent)
        try:
            write_atomic(out, render_house_plan(loaded, base_dir=base_dir, size_px=size))
        except OSError as exc:
            _write_failed(exc)
        _out.print(str(out), markup=False, highlight=False)
        return
    scene = loaded
    try:
        if unit is None:
            png = (
                render_view(scene, topdown_view(scene), base_dir=base_dir, size_px=size, backend="auto")
                if gl
                else render_topdown(scene, base_dir=base_dir, size_px=size)
            )
        else:
            from scenemosaic.evolve import unit_view_png
            from scenemosaic.scene import UnitLayout

            if scene.structure is None or unit not in {u.anchor_id for u in scene.structure.units}:
                anchors = ", ".join(u.anchor_id for u in scene.structure.units) if scene.structure else "none (run generate first)"
                _err.print(f"[red]error:[/red] no unit anchored at {escape(repr(unit))}; units: {escape(anchors)}")
                raise typer.Exit(code=EXIT_BAD_INPUT)
            png = unit_view_png(
                scene, UnitLayout.from_scene(scene, unit), base_dir=base_dir, size_px=size, backend="auto" if gl else "pillow"
            )
    except SceneMosaicError as exc:
        _err.print(f"[red]error:[/red] {escape(str(exc))}")
        raise typer.Exit(code=EXIT_BAD_INPUT) from exc
    _writable_folder(out.parent)
    try:
        write_atomic(out, png)
    except OSError as exc:
        _write_failed(exc)
    _out.print(str(out), markup=False, highlight=False)


@app.command()
def edit(
    path: Annotated[Path, typer.Argument(metavar="SCENE", help="A generate output folder (its base/), a scene folder or file.")],
    expressions: Annotated[list[str], typer.Argument(metavar="EXPR...", help="Pose expressions, e.g. 'chair_0.center.u = table_0.bbox.max_u + 0.3'.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Folder for the edited scene (every delivered format, like base/).")],
    unit: Annotated[str | None, typer.Option("--unit", help="The unit (anchor id) the expressions act in; default: the one unit all targets belong to.")] = None,
    variant: VariantOpt = None,
    room: RoomOpt = None,
    settle: Annotated[
        bool, typer.Option("--settle", help="Settle the edited scene in MuJoCo (generate's stabilize) before checking it.")
    ] = False,
    allow_invalid: Annotated[
        bool, typer.Option("--allow-invalid", help="Write the edited scene even when the edit leaves new collisions or objects out of bounds.")
    ] = False,
    allow_partial: AllowPartialOpt = False,
    log_level: LogLevelOpt = "warning",
) -> None:
    """Move objects of one local unit with the pose expression language (docs/evolution.md), check
    the result (collisions, out of bounds) and write it.

    An edit that adds a collision or an object out of bounds is refused (exit 2) unless
    --allow-invalid; --settle lets physics settle the edited scene first. In a house, --room names
    the room to edit; the whole house is written, that room changed.
    """
    from scenemosaic.exchange import deliver_scene
    from scenemosaic.scene import House

    loaded, base_dir = _load_any(path, variant, allow_partial=allow_partial)
    house: House | None = None
    if isinstance(loaded, House):
        house, scene = loaded, _room_or_exit(loaded, room, path)
    elif room is not None:
        scene, base_dir = _load_or_exit(path, variant, room, allow_partial)
    else:
        scene = loaded
    try:
        edited = scene.edit(expressions, unit=unit)
        if settle:
            from scenemosaic.assets import HullCache
            from scenemosaic.physics import stabilize_scene_sync

            edited, _ = stabilize_scene_sync(edited, base_dir=base_dir, hull_cache=HullCache())
        check = _edit_check(scene, edited, base_dir)
        edited_house = house.with_rooms([edited if r.id == scene.id else r for r in house.rooms]) if house else None
        if house is not None and edited_house is not None:  # what only the whole house shows
            check.new += _house_edit_check(house, edited_house)
        _out.print(check.summary, markup=False, highlight=False)
        if check.new and not allow_invalid:
            _err.print(
                f"[red]error:[/red] the edit leaves {escape(', '.join(check.new))}; nothing written"
                " (try --settle, or write it anyway with --allow-invalid)",
                highlight=False,
            )
            raise typer.Exit(code=EXIT_BAD_INPUT)
        _writable_folder(out)
        if edited_house is not None:
            files = deliver_scene(edited_house, out, base_dir)
        else:
            files = deliver_scene(edited, out, base_dir)
    except SceneMosaicError as exc:
        _err.print(f"[red]error:[/red] {escape(str(exc))}")
        raise typer.Exit(code=EXIT_BAD_INPUT) from exc
    except OSError as exc:
        _write_failed(exc)
    _out.print(f"{out}: {', '.join(files)}", markup=False, highlight=False)


def _house_edit_check(before: House, after: House) -> list[str]:
    """What an edit of one room adds that only the house shows: a door blocked, an object across a
    wall, a room cut off from the others (``metrics.house_checks``)."""
    from scenemosaic.metrics import house_checks

    old, new = house_checks(before), house_checks(after)
    added = [f"a door blocked by {b}" for b in new["door_blockers"] if b not in old["door_blockers"]]
    crossing = {c.split(" (")[0] for c in old["wall_crossings"]}  # by object: its depth may change
    added += [f"an object across a wall: {c}" for c in new["wall_crossings"] if c.split(" (")[0] not in crossing]
    added += [f"room {r} cut off from the house" for r in new["unreachable_rooms"] if r not in old["unreachable_rooms"]]
    return added


class _EditCheck:
    """The edited scene's collisions and objects out of bounds, and those the edit added."""

    def __init__(self, summary: str, new: list[str]) -> None:
        self.summary = summary
        self.new = new


def _edit_check(before: Scene, after: Scene, base_dir: Path | None) -> _EditCheck:
    """Check ``after`` as validation does (hull penetration deeper than the tolerance; footprint
    over its support surface), and name what ``before`` did not already have."""
    from scenemosaic.assets import HullCache
    from scenemosaic.physics import check_out_of_bounds, collision_report_for, object_shape

    cache = HullCache()
    shapes = {o.id: object_shape(o, base_dir, cache=cache) for o in after.objects}

    def problems(scene: Scene) -> tuple[dict[frozenset[str], str], dict[str, str]]:
        pairs = {
            frozenset((p.a, p.b)): f"{p.a} × {p.b} ({p.depth_m * 100:.1f} cm)"
            for p in collision_report_for(scene, shapes).pairs
        }
        oob = {
            o.object_id: f"{o.object_id} {o.inside_fraction:.0%} over {o.anchor_id}"
            for o in check_out_of_bounds(scene, shapes=shapes).objects
        }
        return pairs, oob

    old_pairs, old_oob = problems(before)
    pairs, oob = problems(after)
    summary = (
        f"check: collision pairs {len(pairs)}"
        + (f" ({'; '.join(pairs.values())})" if pairs else "")
        + f", out of bounds {len(oob)}"
        + (f" ({'; '.join(oob.values())})" if oob else "")
    )
    new = [f"a collision {text}" for key, text in pairs.items() if key not in old_pairs]
    new += [f"out of bounds {text}" for key, text in oob.items() if key not in old_oob]
    return _EditCheck(summary, new)


@app.command()
def schema(
    out: Annotated[Path | None, typer.Option("--out", "-o", help="Write to this file instead of stdout.")] = None,
) -> None:
    """Print (or write) the JSON Schema of scene.json."""
    from scenemosaic.scene import Scene, write_atomic

    text = json.dumps(Scene.model_json_schema(), indent=2, sort_keys=True) + "\n"
    if out is None:
        typer.echo(text, nl=False)
    else:
        try:
            write_atomic(out, text)
        except OSError as exc:
            _write_failed(exc)


def main() -> None:
    """Console-script entry point."""
    try:
        app()
    except KeyboardInterrupt:  # Ctrl-C as the command starts, before it handles signals itself
        _err.print("[yellow]interrupted[/yellow] before the command started: nothing written")
        raise SystemExit(EXIT_SIGINT) from None


if __name__ == "__main__":
    main()
