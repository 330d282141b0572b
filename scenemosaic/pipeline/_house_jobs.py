"""What a house run sends its worker processes and what they answer: typed messages, one JSON line
each way (``scenemosaic._processes`` carries the lines; ``pipeline/_workers.py`` sends the jobs,
``pipeline/_house.py`` runs them).

A job is one of :data:`HouseJob` (told apart by ``kind``): a room to run (:class:`RoomJob`, answered
by the room's :class:`~scenemosaic.pipeline.RoomOutcome`), some parts of a house's delivery to
write (:class:`ExportJob`, answered by :class:`ExportReply`) or, once a run is over and its workers
are kept for the next, the memos to forget (:class:`ForgetJob`, answered by :class:`ForgetReply`).
The batch's jobs travel the same way as its own models (``batch.JobSpec``, ``batch.JobOutcome``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, TypeAdapter

from scenemosaic.scene import Scene

__all__ = ["HOUSE_JOB", "ExportJob", "ExportReply", "ForgetJob", "ForgetReply", "HouseJob", "RoomJob"]


class _Message(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class RoomJob(_Message):
    """Run one room of a house through the plan's room stages, from its scene as the house import
    gave it, in ``root``'s ``rooms/<room id>/``."""

    kind: Literal["room"] = "room"
    room: Scene
    input: Path
    """The house run's input (the room's checkpoint is keyed to its content)."""
    root: Path
    """The house run's output folder."""
    base_dir: Path
    """The folder the input's relative mesh paths start from."""
    config: dict[str, Any]
    """The run's settings as ``pipeline.config_record`` writes them."""
    resume: bool = False
    restart_stale: bool = False


class ExportJob(_Message):
    """Write the ``parts`` (``exchange.delivery_parts()``) of the house whose native files are in ``folder``."""

    kind: Literal["export"] = "export"
    folder: Path
    parts: list[str]
    config: dict[str, Any]


class ForgetJob(_Message):
    """The run is over and the worker kept for the next: drop what the run derived (its memos)."""

    kind: Literal["forget"] = "forget"


HouseJob = Annotated[RoomJob | ExportJob | ForgetJob, Field(discriminator="kind")]
"""A job of a house run's worker, by its ``kind``."""

HOUSE_JOB: TypeAdapter[RoomJob | ExportJob | ForgetJob] = TypeAdapter(HouseJob)
"""Reads a job line (``HOUSE_JOB.validate_json(line)``)."""


class ExportReply(_Message):
    """The files of the house folder once the parts are written, or why they are not."""

    files: list[str] = []
    error: str | None = None


class ForgetReply(_Message):
    """How many memo entries the worker dropped."""

    forgotten: int
