"""The image front end as one call: photograph -> inventory -> masks -> verification -> 3D -> scene.

:func:`perceive` is what ``generate photo.jpg`` runs in its import stage. Every step is
checked before the next one starts, and the photograph is checked before any of them (size,
readability), so bad input fails early and costs nothing. What it saw is written to
``perception/`` in the output folder: the photograph, ``inventory.json`` (which
``--detections`` reads back), one mask PNG per object, the meshes of a mesh reconstructor and
``perception.json`` (the camera, the fit, every verification request).
"""

from __future__ import annotations

import asyncio
import inspect
import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import structlog

from scenemosaic.agents import AgentLog, AgentPolicy, run_agent, run_blocking
from scenemosaic.exceptions import ModelConfigError, UsageError
from scenemosaic.models import CallClock, Model, ModelSettings
from scenemosaic.perception._agents import (
    MAX_VERIFY_ROUNDS,
    InventoryAgent,
    PerceptionState,
    VerifyAgent,
    support_candidate,
)
from scenemosaic.perception._frame import at_camera_height, recover_frame
from scenemosaic.perception._image import Camera, SceneImage, load_image
from scenemosaic.perception._inventory import DetectedObject, Inventory, Placement, clipped, read_detections
from scenemosaic.perception._reconstruct import Reconstruction, Reconstructor, SeenObject
from scenemosaic.perception._segment import BoxSegmenter, ObjectMask, Segmenter, segmenter_for
from scenemosaic.scene import (
    Room,
    RunFolder,
    Scene,
    sanitize_id,
    traits,
    unique_id,
    write_atomic,
)

__all__ = ["PERCEPTION_FOLDER", "PerceptionResult", "perceive", "reconstructor_for"]

log = structlog.get_logger(__name__)

PERCEPTION_FOLDER = RunFolder.PERCEPTION
"""Where ``generate`` writes what perception saw, inside the output folder."""


@dataclass
class PerceptionResult:
    """What :func:`perceive` made of a photograph."""

    scene: Scene
    inventory: list[DetectedObject]
    masks: dict[str, ObjectMask]
    camera: Camera
    reconstruction: Reconstruction
    report: dict[str, Any] = field(default_factory=dict)
    agents: AgentLog = field(default_factory=AgentLog)
    """The inventory and verification agents' results: outcomes, fallbacks, requests."""


def reconstructor_for(spec: str | Reconstructor, *, clock: CallClock | None = None, camera_height: float | None = None) -> Reconstructor:
    """A reconstructor from its name (``auto``, ``box-lifter``, ``sam3d[:CONFIG]`` or an
    ``http(s)://`` URL) or the object itself. ``auto``: SAM 3D when installed, else the box lifter.
    ``clock``: the run's clock, which bounds an HTTP reconstructor's calls. ``camera_height``: a
    known camera height, which the box lifter uses before placing what rests or hangs (other
    reconstructors' results are scaled to it afterwards, :func:`at_camera_height`)."""
    from scenemosaic.exceptions import MissingExtraError
    from scenemosaic.perception._lift import BoxLifter
    from scenemosaic.perception._reconstruct import RECONSTRUCTOR_NAMES, HTTPReconstructor, Sam3dReconstructor

    if isinstance(spec, BoxLifter) and spec.camera_height is None and camera_height is not None:
        return BoxLifter(room_lines=spec.room_lines, camera_height=camera_height)
    if not isinstance(spec, str):
        return spec
    name = spec.strip()
    if name.startswith(("http://", "https://")):
        return HTTPReconstructor(name, clock=clock)
    if name in ("box-lifter", "box_lifter", "boxlifter"):
        return BoxLifter(camera_height=camera_height)
    if name == "sam3d" or name.startswith("sam3d:"):
        return Sam3dReconstructor(name.partition(":")[2] or None)
    if name == "auto":
        try:
            return Sam3dReconstructor()
        except (MissingExtraError, UsageError):
            return BoxLifter(camera_height=camera_height)
    raise UsageError(f"unknown reconstructor {spec!r}; choose one of: {', '.join(RECONSTRUCTOR_NAMES)}")


def _seen(inventory: list[DetectedObject], masks: dict[str, ObjectMask]) -> list[SeenObject]:
    """Each object with its mask, where it rests and on what: the inventory's word first, then
    its category's usual placement; a small object on a surface rests on the furniture whose
    box holds its lower edge (:func:`support_candidate`). One with no such furniture in view
    keeps ``surface`` without a parent: the reconstructor decides where it rests (on the floor,
    on furniture out of view, on a wall), after the camera's fit, which it must not sway."""
    ids = {o.id for o in inventory}
    parents: dict[str, str | None] = {}
    placements: dict[str, Placement] = {}
    for o in inventory:
        placement = o.placement or traits(o.category).placement
        parent = o.on if o.on in ids else None
        if placement == "surface" and parent is None:
            parent = support_candidate(o, inventory)
        parents[o.id], placements[o.id] = parent, placement
    for oid in parents:  # a loop of 'on' (a model's answer) is cut where it is found first
        seen, cur = {oid}, parents[oid]
        while cur is not None and cur not in seen:
            seen.add(cur)
            cur = parents[cur]
        if cur == oid:
            parents[oid] = None
    out = []
    for o in inventory:
        parent = parents[o.id]
        rest: Placement = "surface" if parent is not None else placements[o.id]
        out.append(SeenObject(detection=o, mask=masks[o.id], placement=rest, parent=parent))
    return out


async def perceive(
    image_path: str | Path,
    model: Model,
    *,
    detections: str | Path | None = None,
    segmenter: str | Segmenter = "auto",
    reconstructor: str | Reconstructor = "auto",
    hfov_deg: float | None = None,
    camera_height_m: float | None = None,
    out_dir: str | Path | None = None,
    policy: AgentPolicy | None = None,
    settings: ModelSettings | None = None,
    seed: int = 0,
    max_rounds: int = MAX_VERIFY_ROUNDS,
    clock: CallClock | None = None,
    agent_log: AgentLog | None = None,
) -> PerceptionResult:
    """Turn a photograph into a scene (see the module's docstring).

    The inventory comes from ``detections`` (COCO or inventory JSON) with the offline ``rules``
    model, or from ``model`` when it is a vision model (``detections`` are then its hints). A
    text-only model (``vision`` off) or the rules model without detections fails at once,
    before anything is segmented. ``out_dir``: where ``perception/`` is written (nothing when
    ``None``). ``camera_height_m``: the camera's height above the floor when the user knows it
    (:func:`at_camera_height`: it replaces the scale read from the objects' usual sizes).
    ``clock``: the run's clock (``RunModel.clock``: request time-out and deadline),
    which bounds every call to an HTTP segmenter or reconstructor. ``agent_log`` receives the
    inventory and verification agents' results (it is the result's ``agents``; default: a new
    one), also when perception fails.
    """
    if camera_height_m is not None and not (math.isfinite(camera_height_m) and camera_height_m > 0.0):
        raise UsageError(f"the camera's height must be a positive number of metres, got {camera_height_m!r}")
    image = await asyncio.to_thread(load_image, image_path)
    hints = await asyncio.to_thread(read_detections, detections, image.width, image.height, image_name=image.path.name) if detections else []
    if not model.uses_rule_solvers and not model.vision:
        raise ModelConfigError(
            f"{model.name} is set up as text-only (the `vision` setting is off), and reading a photograph needs a vision "
            "model: turn `vision` on (vision=True; drop --no-vision or SCENEMOSAIC_VISION=0), or give the objects as "
            "detections (--detections boxes.json) with --model rules"
        )
    if model.uses_rule_solvers and not hints:
        raise UsageError(
            "no object inventory for the photograph: with the offline rules model pass detections "
            "(--detections boxes.json, COCO or an inventory JSON), or use a vision model (--model openai:<model>)"
        )
    seg = await asyncio.to_thread(lambda: segmenter_for(segmenter, clock=clock))
    try:
        rec_backend = await asyncio.to_thread(lambda: reconstructor_for(reconstructor, clock=clock, camera_height=camera_height_m))
    except BaseException:
        await _close(seg)
        raise
    folder = Path(out_dir) / PERCEPTION_FOLDER if out_dir is not None else None
    try:
        return await _perceive(
            image, model, hints, seg, rec_backend, hfov_deg, folder, policy, settings, seed, max_rounds,
            agent_log if agent_log is not None else AgentLog(), camera_height_m,
        )  # fmt: skip
    finally:
        await _close(seg)
        await _close(rec_backend)


async def _close(backend: object) -> None:
    """Close a backend that holds anything (``aclose`` or ``close``)."""
    aclose = getattr(backend, "aclose", None)
    if callable(aclose):
        await aclose()
        return
    close = getattr(backend, "close", None)
    if callable(close):
        close()


async def _backend_call(fn: Callable[..., Any], *args: Any) -> Any:
    """Call a backend method: a coroutine function is awaited on the loop (a signal cancels it at
    once), a plain function runs in a worker thread."""
    if inspect.iscoroutinefunction(fn):
        return await fn(*args)
    result = await run_blocking(fn, *args)
    return await result if inspect.isawaitable(result) else result


async def _perceive(
    image: SceneImage,
    model: Model,
    hints: list[DetectedObject],
    seg: Segmenter,
    rec_backend: Reconstructor,
    hfov_deg: float | None,
    folder: Path | None,
    policy: AgentPolicy | None,
    settings: ModelSettings | None,
    seed: int,
    max_rounds: int,
    agents: AgentLog,
    camera_height_m: float | None = None,
) -> PerceptionResult:
    camera = image.camera(hfov_deg)
    placeholder = Scene(id="photo", room=Room.rectangle(0.0, 0.0, 1.0, 1.0), objects=[])
    state = PerceptionState(scene=placeholder, seed=seed, policy=policy or AgentPolicy(), image=image, hints=hints)
    listed = await run_agent(InventoryAgent(), state, model, settings, log=agents)
    log.info("perception_inventory", objects=len(state.inventory), answered_by=listed.outcome.answered_by)

    async def cut(objs: list[DetectedObject], how: Segmenter) -> None:
        for o in objs:
            state.masks[o.id] = await _backend_call(how.segment, image, o.label, o.box)

    await cut(state.inventory, seg)
    rounds: list[dict[str, Any]] = []
    for rnd in range(1, max_rounds + 1):
        state.round = rnd
        checked = await run_agent(VerifyAgent(), state, model, settings, log=agents)
        requests = state.requests
        rounds.append({"round": rnd, "answered_by": checked.outcome.answered_by, "requests": [r.words() for r in requests]})
        if not requests:
            break
        same_box = _apply_requests(state, requests)
        # a segmenter gives the same mask for the same box: asked again without a new box, the box itself stands in
        await cut([o for o in state.inventory if o.id not in state.masks and o.id not in same_box], seg)
        await cut([o for o in state.inventory if o.id in same_box], BoxSegmenter())
        state.memory += [r.words() for r in requests]
    inventory = state.inventory
    if folder is not None:  # kept before the 3D step, which may fail on a backend
        await asyncio.to_thread(_write_seen, folder, image, inventory, state.masks)
    seen = _seen(inventory, state.masks)
    reconstruction: Reconstruction = await _backend_call(rec_backend.reconstruct, image, camera, seen)
    given: dict[str, float] = {}
    if camera_height_m is not None:  # the user measured it: it sets the room's scale
        reconstruction, factor = at_camera_height(reconstruction, float(camera_height_m))
        factor *= float(reconstruction.report.get("scale_from_camera_height", 1.0))  # what the reconstructor scaled itself
        given = {"camera_height_given_m": float(camera_height_m), "scale_from_camera_height": round(factor, 4)}
    meshes = {o.id: o.mesh for o in reconstruction.objects if o.mesh is not None}
    uris = {oid: f"meshes/{oid}.glb" for oid in meshes}
    scene = recover_frame(
        reconstruction,
        camera,
        scene_id=sanitize_id(image.path.stem, fallback="photo"),
        source=str(image.path),
        mesh_uris=uris,
        metadata={"image": {"file": image.path.name, "width": image.width, "height": image.height}},
    )
    report: dict[str, Any] = {
        "image": str(image.path),
        "size": [image.width, image.height],
        "camera": {"hfov_deg": round(camera.hfov_deg, 3), "focal_source": camera.source},
        "inventory": {"objects": len(inventory), "answered_by": listed.outcome.answered_by, "hints": len(hints)},
        "segmenter": seg.name,
        "reconstructor": rec_backend.name,
        "verification": rounds,
        "mask_coverage": {o.id: round(state.masks[o.id].area / max(1.0, (o.box[2] - o.box[0]) * (o.box[3] - o.box[1])), 3) for o in inventory},
        "placements": {s.detection.id: (s.placement if s.parent is None else f"on {s.parent}") for s in seen},
        **{k: v for k, v in reconstruction.report.items() if k != "reconstructor"},
    }
    if given:  # the scene stands at the given height; the fit's own reading is kept beside it
        report["camera_height_fit_m"] = report.get("camera_height_m")
        report["camera_height_m"] = given["camera_height_given_m"]
        report.update(given)
    if folder is not None:
        await asyncio.to_thread(_write_result, folder, meshes, reconstruction, report)
    return PerceptionResult(scene, inventory, dict(state.masks), camera, reconstruction, report, agents)


def _apply_requests(state: PerceptionState, requests: list[Any]) -> set[str]:
    """Apply one round's requests; the ids asked to be segmented again with their box unchanged."""
    image = state.need_image()
    scaled = state.view_size() != (image.width, image.height)
    requests = [r.model_copy(update={"box": state.from_view(r.box)}) if scaled and r.box is not None else r for r in requests]
    same_box: set[str] = set()
    taken = {o.id for o in state.inventory}
    inventory = list(state.inventory)
    for r in requests:
        if r.action == "remove":
            inventory = [o for o in inventory if o.id != r.object_id]
            state.masks.pop(r.object_id, None)
        elif r.action == "add" and r.label and r.box:
            oid = unique_id(sanitize_id(r.object_id or r.label), taken)
            inventory.append(clipped(DetectedObject(id=oid, label=r.label, box=r.box, description=r.reason[:200]), image.width, image.height))
        elif r.action == "resegment":
            for i, o in enumerate(inventory):
                if o.id == r.object_id:
                    new = clipped(o.model_copy(update={"box": r.box}), image.width, image.height) if r.box is not None else o
                    if new.box == o.box:
                        same_box.add(o.id)
                    inventory[i] = new
                    state.masks.pop(o.id, None)
        elif r.action == "set_support":
            inventory = [o.model_copy(update={"on": r.on, "placement": "surface"}) if o.id == r.object_id else o for o in inventory]
    state.inventory = inventory
    return same_box


def _write_seen(folder: Path, image: SceneImage, inventory: list[DetectedObject], masks: dict[str, ObjectMask]) -> None:
    """The photograph, the inventory and the masks (before the 3D step)."""
    folder.mkdir(parents=True, exist_ok=True)
    target = folder / f"photo{image.path.suffix.lower()}"
    if image.path.resolve() != target.resolve():
        write_atomic(target, Path(image.path).read_bytes())
    write_atomic(folder / "inventory.json", Inventory(objects=inventory).model_dump_json(indent=2).encode("utf-8"))
    (folder / "masks").mkdir(exist_ok=True)
    for o in inventory:
        write_atomic(folder / "masks" / f"{o.id}.png", masks[o.id].png(image.width, image.height))


def _write_result(folder: Path, meshes: dict[str, bytes], reconstruction: Reconstruction, report: dict[str, Any]) -> None:
    """The meshes and ``perception.json`` (the report and every object's camera-frame pose)."""
    if meshes:
        (folder / "meshes").mkdir(exist_ok=True)
        for oid, data in meshes.items():
            write_atomic(folder / "meshes" / f"{oid}.glb", data)
    lifted = [
        {
            "id": o.id,
            "category": o.category,
            "placement": o.placement,
            "on": o.parent,
            "position_camera": [round(float(v), 5) for v in o.position],
            "rotation_camera": [round(float(v), 6) for v in np.asarray(o.rotation).ravel()],
            "extents": [round(v, 4) for v in o.extents],
        }
        for o in reconstruction.objects
    ]
    payload = {**report, "objects": lifted}
    write_atomic(folder / "perception.json", (json.dumps(payload, indent=2) + "\n").encode("utf-8"))
