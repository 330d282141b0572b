"""One entry point for every metric of a run: :func:`evaluate` takes a room's scene or a whole house,
each with its variants."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any, overload

from scenemosaic.assets import HullCache
from scenemosaic.metrics._house import _evaluate_house
from scenemosaic.metrics._metrics import evaluate_scenes
from scenemosaic.scene import House, Scene

__all__ = ["evaluate"]


@overload
def evaluate(
    base: Scene, variants: Sequence[Scene] = (), *, base_dir: str | Path | None = None,
    variant_dirs: Sequence[str | Path | None] = (), hull_cache: HullCache | None = None,
    base_checks: dict[str, Any] | None = None, variant_checks: Sequence[dict[str, Any]] | None = None,
) -> dict[str, Any]: ...


@overload
def evaluate(
    base: House, variants: Sequence[House] = (), *, base_dir: str | Path | None = None,
    variant_dirs: Sequence[str | Path | None] = (), hull_cache: HullCache | None = None,
    base_checks: dict[str, Any] | None = None, variant_checks: Sequence[dict[str, Any]] | None = None,
) -> dict[str, Any]: ...


def evaluate(
    base: Scene | House,
    variants: Sequence[Scene] | Sequence[House] = (),
    *,
    base_dir: str | Path | None = None,
    variant_dirs: Sequence[str | Path | None] = (),
    hull_cache: HullCache | None = None,
    base_checks: dict[str, Any] | None = None,
    variant_checks: Sequence[dict[str, Any]] | None = None,
) -> dict[str, Any]:
    """Every metric of a base and its variants, JSON-ready (``scenemosaic evaluate`` prints it).

    A room's scene: ``{"base", "variants", "RelKeep_by_kind", "diversity"}`` (COL, OOB, NAV,
    RelKeep, Div-IoU, Div-N; the semantic judge needs a vision model and is reported as not
    measured). A whole :class:`~scenemosaic.scene.House` (its variants houses too):
    ``{"house": {...}, "rooms": {room id: ...}}``, each room measured as a room is and the house's
    own figures (house NAV, reachability, blocked doors, walls crossed, the diversity); a house
    run hands over the house checks it measured already (``base_checks``, ``variant_checks``).
    ``variant_dirs`` resolve each variant's relative mesh paths (default: ``base_dir``'s role is
    played by none). Mixing a house with room variants, or the reverse, raises ``TypeError``.
    """
    if isinstance(base, House):
        houses = [v for v in variants if isinstance(v, House)]
        if len(houses) != len(variants):
            raise TypeError("the variants of a house are houses")
        return _evaluate_house(
            base, houses, base_dir=base_dir, variant_dirs=variant_dirs, hull_cache=hull_cache,
            base_checks=base_checks, variant_checks=variant_checks,
        )  # fmt: skip
    scenes = [v for v in variants if isinstance(v, Scene)]
    if len(scenes) != len(variants):
        raise TypeError("the variants of a room's scene are scenes")
    if base_checks is not None or variant_checks is not None:
        raise TypeError("base_checks and variant_checks are a house's (house_checks)")
    out: dict[str, Any] = evaluate_scenes(base, scenes, base_dir=base_dir, variant_dirs=variant_dirs, hull_cache=hull_cache)
    return out
