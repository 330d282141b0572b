"""What a ``generate`` run is told (:class:`GenerateConfig`) and what it carries along (:class:`PipelineRun`)."""

from __future__ import annotations

import time
from collections.abc import Awaitable, Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from scenemosaic.models import Model
from scenemosaic.scene import Scene

if TYPE_CHECKING:
    from scenemosaic.agents import FallbackRecord, TaskAgent
    from scenemosaic.assets import HullCache
    from scenemosaic.evolve import LayoutRule

__all__ = [
    "GenerateConfig",
    "GenerateResult",
    "PipelineRun",
    "Stage",
    "StageCallback",
    "StageFn",
    "StageRecord",
]

StageCallback = Callable[[str, str], None]
"""Called as ``callback(stage_name, status)`` with status ``"started"``, ``"done"``, ``"reused"`` or ``"failed"``."""


@dataclass(frozen=True)
class GenerateConfig:
    """Settings of one ``generate`` run."""

    format: str = "auto"
    """Input format (``auto`` or a registered reader: ``native``, ``front3d``, ``procthor``,
    ``holodeck``, ``sam3d``, ``sceneeval``; or ``image``, which ``auto`` picks for ``.png``,
    ``.jpg``... inputs: the image front end, ``docs/perception.md``)."""
    detections: Path | None = None
    """Object detections of a photograph input (``--detections``): COCO (``bbox`` = [x, y, w, h])
    or an inventory JSON. The offline ``rules`` model needs them; a vision model takes them as hints."""
    segmenter: Any = "auto"
    """How a photograph's objects are cut out (``--segmenter``): ``auto``, ``grabcut``, ``box``,
    ``sam3``, an ``http://`` segmentation server, or a :class:`~scenemosaic.perception.Segmenter`."""
    reconstructor: Any = "auto"
    """How a photograph's objects are lifted to 3D (``--reconstructor``): ``auto``, ``box-lifter``,
    ``sam3d[:pipeline.yaml]``, an ``http://`` server, or a :class:`~scenemosaic.perception.Reconstructor`."""
    prompt: str | None = None
    """Draw the room from this text first (``--prompt``): the model's images endpoint
    (``/images/generations``) makes ``OUT/prompt.png``, which then goes through the image front
    end like a photograph. Give no input with it."""
    image_model: str | None = None
    """The images endpoint's model name (``--image-model``); ``None``: the chat model's name."""
    image_size: str = "1024x1024"
    """Size asked of the images endpoint (``--image-size``)."""
    hfov_deg: float | None = None
    """Horizontal field of view of a photograph input, degrees (``--hfov``); ``None``: from its
    EXIF focal length, else :data:`~scenemosaic.perception.DEFAULT_HFOV_DEG`."""
    variants: int = 0
    """Number of diverse whole-scene variants to deliver (m). Above 0, the evolve stage grows each
    unit's structurally different variants (archetypes) beside the refined original, and the
    compose stage selects m diverse valid combinations of them (dynamic max-min greedy on the
    novelty distance), written as ``variant_1/`` ... ``variant_m/`` beside ``base/``; fewer when
    the pool holds fewer distinct valid ones (the report says so)."""
    evolve: bool = True
    """Run the evolve stage (the Critic-Actor refinement of every unit); ``--no-evolve`` delivers
    the stabilized scene as it is. Skipped too when ``stabilize`` is off (it refines a stabilized scene)."""
    evolve_rounds: int = 8
    """Round cap of each layout's Critic-Actor loop (``--rounds``; ``scenemosaic.evolve.MAX_ROUNDS``)."""
    save_views: bool = False
    """Write every unit view the critic sees, per round, as PNG under ``evolve/`` (``--save-views``)."""
    model: str | Model = "rules"
    """Model string (``rules``, ``openai:<model>[@<base_url>]``, ``replay:<cassette.json>``) or a
    :class:`~scenemosaic.models.Model` instance, which the caller keeps ownership of (not closed here)."""
    seed: int = 0
    """Run seed; every random choice derives from it, so equal inputs give identical files."""
    room: str | None = None
    """Room id to take from a multi-room house file."""
    asset_dir: Path | None = None
    """Folder of asset meshes a SceneEval input names by ``assetId`` (default: ``assets/`` beside it)."""
    vision: bool | None = None
    """Force the model's vision setting (``False`` for text-only local servers); ``None`` keeps its default."""
    solver_fallback: bool = True
    """When a real model's answers stay unusable (after retries and repairs), use the agent's rule
    solver and note it in the report (the run is then ``degraded``), instead of failing the run.
    Configuration errors still fail."""
    request_timeout_s: float | None = None
    """Time-out of one model request in seconds (``--request-timeout``); ``None`` keeps the
    model's own. See ``docs/reliability.md`` for the precedence of time-outs."""
    max_concurrency: int | None = None
    """Most model requests in flight at once (``--max-concurrency``); more wait in the client, so
    a request's time-out measures the server's work, not a queue. ``None``: the server's slot
    count when it reports one (llama.cpp), else no limit beyond the task graph's."""
    deadline_s: float | None = None
    """Wall-clock budget for all model requests of the run, in seconds (``--deadline``): once it
    has passed, agents answer with their rule solvers (the run is ``degraded``)."""
    stabilize: bool = True
    """Run the physics stabilization stage."""
    strict: bool = False
    """Treat a ``degraded`` outcome (unresolved collisions, fallen objects, solver fallbacks) as a
    failure: the CLI exits 1 (``--strict``). The files are written either way."""
    overwrite: bool = False
    """Allow writing into an output folder that holds the results of another input."""
    resume: bool = False
    """Continue a stopped run in the same output folder: finished stages (and finished agents of
    the structuring stage) are reused from the run's checkpoints (``--resume``)."""
    cache_dir: Path | None = None
    """Hull cache folder; default ``$SCENEMOSAIC_CACHE`` or ``~/.cache/scenemosaic``."""
    requests_per_minute: float | None = None
    """Client-side request rate for the model (``--rpm``; ``models.RateLimiter``)."""
    tokens_per_minute: float | None = None
    """Client-side token rate for the model (``--tpm``)."""
    rate_limit_dir: Path | None = None
    """Keep the request and token rates in files in this folder (``models.FileTokenBucket``), so
    every run using the folder shares one budget per model: the workers of a batch
    (``OUT/.batch/limits``). ``None``: the rates hold within this run only."""
    reply_cache: Path | None = None
    """Folder of the on-disk model reply cache (``--reply-cache``; ``models.CachedModel``): an
    equal request is answered from it at no cost, so a re-run or retried job never pays twice.
    ``None``: no cache (the rules model makes no requests either way)."""
    priors_dir: Path | None = None
    """ProcTHOR priors folder (receptacles, placement annotations, asset groups) replacing the
    priors shipped with the package."""
    agents: Sequence[TaskAgent[Any, Any]] | None = None
    """Structuring agents the manager may schedule; default
    :data:`~scenemosaic.structure.DEFAULT_AGENTS`. Add a plugin with
    ``agents=[*DEFAULT_AGENTS, MyAgent()]``."""
    layout_rules: Sequence[LayoutRule] = ()
    """Plugin rules of the evolve stage's critic (:data:`~scenemosaic.evolve.LayoutRule`): each
    sees every layout of every unit, and its findings join the built-in ones (``docs/plugins.md``)."""


@dataclass
class StageRecord:
    """Timing and outcome of one pipeline stage, as written to ``report.json``."""

    name: str
    seconds: float = 0.0
    status: str = "pending"
    """``pending``, ``done``, ``skipped``, ``reused`` (from a checkpoint), ``failed`` or ``interrupted``."""
    objects: int | None = None
    detail: dict[str, Any] = field(default_factory=dict)


@dataclass
class GenerateResult:
    """What ``generate`` produced: the final base scene, the output folder and the report; its
    variants and metrics on demand. In Jupyter it displays as a summary table and the contact
    sheet of the base and its variants."""

    scene: Scene
    out_dir: Path
    report: dict[str, Any]
    _variants: list[Scene] | None = field(default=None, init=False, repr=False, compare=False)

    @property
    def base_dir(self) -> Path:
        """The delivered base scene's folder (``out_dir / "base"``)."""
        return self.out_dir / "base"

    @property
    def status(self) -> str:
        """``ok`` or ``degraded`` (a failed run raises instead of returning)."""
        return str(self.report.get("status", "ok"))

    @property
    def variant_dirs(self) -> list[Path]:
        """The variants' folders, ``variant_1`` ... ``variant_n`` (empty without variants)."""
        n = int(self.report.get("variants_written", 0) or 0)
        return [self.out_dir / f"variant_{i}" for i in range(1, n + 1)]

    @property
    def variants(self) -> list[Scene]:
        """The delivered whole-scene variants, read from their folders (on first use)."""
        if self._variants is None:
            from scenemosaic.exchange import read_scene

            self._variants = [read_scene(d) for d in self.variant_dirs]
        return list(self._variants)

    @property
    def metrics(self) -> dict[str, Any] | None:
        """COL, OOB, NAV of the base and each variant, RelKeep and the diversity (``None`` when
        the evaluate stage did not run)."""
        value = self.report.get("metrics")
        return value if isinstance(value, dict) else None

    @property
    def preview_path(self) -> Path | None:
        """The contact sheet (base and variants side by side), else the base's top-down view."""
        for p in (self.out_dir / "contact_sheet.png", self.base_dir / "topdown.png"):
            if p.is_file():
                return p
        return None

    def _repr_png_(self) -> bytes | None:
        """Jupyter shows the preview image."""
        p = self.preview_path
        return p.read_bytes() if p is not None else None

    def _repr_html_(self) -> str:
        """Jupyter shows a summary table (status, objects, each scene's metrics) over the preview."""
        import base64
        import html

        rows = [f"<tr><th>status</th><td>{html.escape(self.status)}</td></tr>"]
        rows.append(f"<tr><th>objects</th><td>{len(self.scene.objects)}</td></tr>")
        rows.append(f"<tr><th>output</th><td><code>{html.escape(str(self.out_dir))}</code></td></tr>")
        out = [f"<table>{''.join(rows)}</table>"]
        m = self.metrics
        if m:
            scenes = [("base", m.get("base") or {})] + [(f"variant_{i}", v) for i, v in enumerate(m.get("variants") or [], 1)]
            keys = ["COL", "OOB", "NAV", "RelKeep"]
            head = "".join(f"<th>{k}</th>" for k in keys)
            body = "".join(
                f"<tr><td>{name}</td>" + "".join(f"<td>{html.escape(str(v.get(k, '')))}</td>" for k in keys) + "</tr>"
                for name, v in scenes
            )
            out.append(f"<table><tr><th></th>{head}</tr>{body}</table>")
            div = m.get("diversity")
            if isinstance(div, dict):
                out.append(f"<p>Div-IoU {html.escape(str(div.get('Div-IoU')))}, Div-N {html.escape(str(div.get('Div-N')))}</p>")
        png = self._repr_png_()
        if png is not None:
            data = base64.b64encode(png).decode("ascii")
            out.append(f'<img src="data:image/png;base64,{data}" style="max-width:100%"/>')
        return "\n".join(out)


@dataclass
class PipelineRun:
    """Mutable state threaded through the stages."""

    input_path: Path
    out_dir: Path
    config: GenerateConfig
    base_dir: Path
    """Folder relative mesh paths of the input start from."""
    scene: Scene | None = None
    records: list[StageRecord] = field(default_factory=list)
    hull_cache: HullCache | None = None
    """The run's CoACD hull cache, opened on first use and shared by the stages."""
    validation: dict[str, Any] | None = None
    """The validate stage's full report (JSON-ready), written to ``report.json``."""
    fallbacks: list[FallbackRecord] = field(default_factory=list)
    """Agents answered by their rule solvers instead of the model."""
    warnings: list[str] = field(default_factory=list)
    """What makes the outcome ``degraded``, in words."""
    metrics: dict[str, Any] | None = None
    """The evaluate stage's metrics (base, variants, diversity), written to ``report.json``."""
    variants_written: int = 0
    """Whole-scene variants the compose stage wrote (``variant_<i>/``)."""
    started: float = field(default_factory=time.monotonic)
    """``time.monotonic()`` when the run began: the run deadline counts from here."""

    @property
    def checkpoint_dir(self) -> Path:
        """Where stage checkpoints and the agents' run store live (``out/.checkpoint``)."""
        return self.out_dir / ".checkpoint"


StageFn = Callable[[PipelineRun, StageRecord], Awaitable[None]]
"""A stage's body: reads and updates the run, records its figures in the stage record."""


@dataclass(frozen=True)
class Stage:
    """One named step of the pipeline."""

    name: str
    run: StageFn
