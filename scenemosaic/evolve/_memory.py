"""Layout memory: what each round of one evolving layout saw, asked, wrote and got.

Serialized into the critic's and actor's prompts from the second round on, so a model (and
the rule critic) can see repeated failures: an object pushed back and forth along one axis
(**oscillation**), or moved out of bounds round after round (**boundary violations**). The
critic then pivots: another object, another axis or side, or no change.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from pydantic import BaseModel, ConfigDict, Field

__all__ = ["OSCILLATION_MIN_MOVE", "LayoutMemory", "RoundRecord"]

OSCILLATION_MIN_MOVE = 0.02
"""Moves shorter than this (metres) do not count toward an oscillation."""


class RoundRecord(BaseModel):
    """One round of the Critic-Actor loop."""

    model_config = ConfigDict(extra="forbid")

    round: int
    poses: dict[str, tuple[float, float, float]] = Field(description="Initial (u, v, rotation) per object.")
    collisions: list[tuple[str, str, int]] = Field(default_factory=list, description="Colliding pairs and contact counts.")
    out_of_bounds: list[str] = Field(default_factory=list)
    score: int | None = None
    notes: list[str] = Field(default_factory=list)
    expressions: list[str] = Field(default_factory=list)
    resolved: dict[str, tuple[float, float, float]] = Field(default_factory=dict, description="Poses after the actor's expressions.")
    refused: list[str] = Field(default_factory=list, description="Actor replies the sandbox refused, with why.")
    enforced: list[str] = Field(
        default_factory=list, description="Objects the actor left as they were although a rule required a fix: the rule's fix was applied."
    )


@dataclass
class LayoutMemory:
    """The rounds of one evolving layout, oldest first."""

    rounds: list[RoundRecord] = field(default_factory=list)

    def add(self, record: RoundRecord) -> None:
        self.rounds.append(record)

    def _tracks(self) -> dict[str, list[tuple[float, float, float]]]:
        tracks: dict[str, list[tuple[float, float, float]]] = {}
        for r in self.rounds:
            for oid, pose in r.poses.items():
                tracks.setdefault(oid, []).append(pose)
            if r.resolved and r is self.rounds[-1]:
                for oid, pose in r.resolved.items():
                    tracks.setdefault(oid, []).append(pose)
        return tracks

    def oscillating(self) -> dict[str, str]:
        """Objects moved back and forth along one axis (or turned back and forth) in the last
        three poses, with the axis: ``{"chair_0": "u"}``."""
        out: dict[str, str] = {}
        for oid, poses in self._tracks().items():
            if len(poses) < 3:
                continue
            a, b, c = poses[-3:]
            for axis, k in (("u", 0), ("v", 1)):
                m1, m2 = b[k] - a[k], c[k] - b[k]
                if abs(m1) >= OSCILLATION_MIN_MOVE and abs(m2) >= OSCILLATION_MIN_MOVE and m1 * m2 < 0:
                    out[oid] = axis
            t1 = (b[2] - a[2] + 180) % 360 - 180
            t2 = (c[2] - b[2] + 180) % 360 - 180
            if abs(t1) > 5 and abs(t2) > 5 and t1 * t2 < 0:
                out.setdefault(oid, "rotation")
        return out

    def boundary_repeats(self) -> list[str]:
        """Objects out of bounds in each of the last two rounds although the actor moved them."""
        if len(self.rounds) < 2:
            return []
        a, b = self.rounds[-2], self.rounds[-1]
        moved = {k for k, p in a.resolved.items() if k in a.poses and math.dist(p[:2], a.poses[k][:2]) > 1e-3}
        return sorted(set(a.out_of_bounds) & set(b.out_of_bounds) & moved)

    def avoid(self) -> set[str]:
        """Objects the next fixes should leave alone or handle differently."""
        return set(self.oscillating()) | set(self.boundary_repeats())

    def text(self, max_rounds: int = 4) -> str:
        """The memory as compact lines for a prompt (the last ``max_rounds`` rounds)."""
        if not self.rounds:
            return "(first round: no memory yet)"
        lines: list[str] = []
        for r in self.rounds[-max_rounds:]:
            lines.append(f"round {r.round}: score {r.score if r.score is not None else '-'}")
            if r.collisions:
                lines.append("  collisions: " + ", ".join(f"{a}~{b} ({n} contacts)" for a, b, n in r.collisions))
            if r.out_of_bounds:
                lines.append("  out of bounds: " + ", ".join(r.out_of_bounds))
            for n in r.notes:
                lines.append(f"  note: {n}")
            for e in r.expressions:
                lines.append(f"  expression: {e}")
            for oid, (u, v, rot) in sorted(r.resolved.items()):
                before = r.poses.get(oid)
                if before is None or math.dist(before[:2], (u, v)) > 1e-3 or abs(before[2] - rot) > 0.05:
                    lines.append(f"  moved {oid} to u={u:.2f} v={v:.2f} rotation={rot:.0f}")
            for x in r.refused:
                lines.append(f"  refused: {x}")
            if r.enforced:
                lines.append("  rule fixes applied for: " + ", ".join(r.enforced))
        osc = self.oscillating()
        if osc:
            lines.append("oscillating (pivot: another object, axis or side, or leave it): " + ", ".join(f"{k} along {a}" for k, a in sorted(osc.items())))
        rep = self.boundary_repeats()
        if rep:
            lines.append("moved out of bounds again and again: " + ", ".join(rep))
        return "\n".join(lines)
