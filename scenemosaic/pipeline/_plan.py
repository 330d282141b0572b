"""The stage plan of a run, in one place: which stages a run goes through, in which order, for its
input and settings. The driver runs the plan, the progress displays count it (the driver announces
it before the first stage), and a house's rooms run the room plan it names.

* a room: :data:`~scenemosaic.pipeline.STAGES` (import → assets → structure → stabilize → doors →
  evolve → compose → validate → evaluate → export), with the clutter stage after compose when
  ``clutter`` is not ``keep``;
* a whole house (``exchange.is_house_source``): :data:`HOUSE_STAGES` (import → rooms → compose →
  validate → evaluate → export): the room's own import, compose, validate, evaluate and export
  (they work on the run's world, a house here), with the ``rooms`` stage in place of assets ...
  evolve, each room running the room stages up to its own variants (compose, then clutter when
  asked for).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from scenemosaic.pipeline._clutter import CLUTTER_STAGE
from scenemosaic.pipeline._config import GenerateConfig
from scenemosaic.pipeline._house import ROOMS_STAGE, is_house_input
from scenemosaic.pipeline._stages import STAGES
from scenemosaic.pipeline._state import Stage

__all__ = ["HOUSE_STAGES", "HOUSE_STAGE_NAMES", "Plan", "plan", "room_plan"]

_BY_NAME = {stage.name: stage for stage in STAGES}

HOUSE_STAGES: tuple[Stage, ...] = (
    _BY_NAME["import"],
    ROOMS_STAGE,
    *(_BY_NAME[name] for name in ("compose", "validate", "evaluate", "export")),
)
"""The stages of a whole-house run, in order: the room's stages (:data:`STAGES`) with ``rooms`` in
place of assets ... evolve (``rooms`` runs the plan's room stages in every room)."""

HOUSE_STAGE_NAMES: tuple[str, ...] = tuple(stage.name for stage in HOUSE_STAGES)
"""The names of :data:`HOUSE_STAGES`, in order."""


@dataclass(frozen=True)
class Plan:
    """What a run will go through."""

    stages: tuple[Stage, ...]
    """The run's stages, in order."""
    house: bool = False
    """Whether the input is run as a whole house."""
    room_stages: tuple[Stage, ...] = ()
    """A house run: the stages each of its rooms goes through (in the ``rooms`` stage)."""

    @property
    def names(self) -> tuple[str, ...]:
        """The stages' names, in order."""
        return tuple(stage.name for stage in self.stages)


def room_plan(config: GenerateConfig, *, in_house: bool = False) -> tuple[Stage, ...]:
    """The stages of a room's run: every stage, or (``in_house``) a house's room's, up to its own
    variants; the clutter stage after compose when ``clutter`` is not ``keep``."""
    names = [stage.name for stage in STAGES]
    after_compose = names.index("compose") + 1
    stages = STAGES[:after_compose] if in_house else STAGES
    if config.clutter == "keep":
        return stages
    return (*stages[:after_compose], CLUTTER_STAGE, *stages[after_compose:])


def plan(input_path: Path, config: GenerateConfig) -> Plan:
    """The plan of a run of ``input_path`` with ``config`` (reads the input to tell a house)."""
    if is_house_input(input_path, config):
        return Plan(HOUSE_STAGES, house=True, room_stages=room_plan(config, in_house=True))
    return Plan(room_plan(config))
