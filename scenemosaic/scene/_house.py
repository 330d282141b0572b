"""A house: rooms that share walls and doors, and the checks that span them.

A :class:`House` holds one :class:`Scene` per room, every one in the house's world frame (the
floors tile the plan; see ``docs/houses.md``). The house is the root of the scene tree and each
room a top-level unit holding its own anchors (floor, walls, ceiling, furniture), so a room's
scene is exactly what a one-room run works on. What a room alone cannot see is between rooms:

* **doorways** (:meth:`House.doorways`) — a door cut into two rooms' walls at the same place is
  one doorway joining them; a door on one room's wall only leads outside;
* **door clearance** (:func:`door_zones`, :func:`door_blockers`) — the zone in front of every
  door on each side, ``DOOR_CLEARANCE_DEPTH_M`` deep and as wide as the door, holds nothing a
  person or robot would walk into;
* **reachability** (:func:`house_walkable`) — one walkable raster over every floor and through
  every doorway: a robot of ``ROBOT_RADIUS`` gets from any room to any other;
* **walls** (:func:`wall_crossings`) — no object of a room reaches past its room's floor into a
  wall or the next room (``WALL_CROSSING_TOLERANCE_M``).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from pydantic import Field, field_validator
from shapely.geometry import Point, Polygon
from shapely.ops import unary_union

from scenemosaic._memo import Memo
from scenemosaic.scene._geometry import FloatArray
from scenemosaic.scene._limits import house_problem
from scenemosaic.scene._model import Opening, Provenance, Scene, SceneObject, Wall, _Model, _plan_png
from scenemosaic.scene._planar import convex_hull_2d
from scenemosaic.scene._walkable import (
    ROBOT_RADIUS,
    WALK_MAX_HEIGHT,
    FloorRaster,
    Walkable,
    is_thin,
    kept_floor_share,
)

__all__ = [
    "DOOR_CLEARANCE_DEPTH_M",
    "DOOR_MATCH_TOLERANCE_M",
    "DOOR_ZONE_ROOM_LEFT_M",
    "HOUSE_CELL_M",
    "MIN_PASSAGE_M",
    "WALL_CROSSING_TOLERANCE_M",
    "WINDOW_REACH_M",
    "DoorBlock",
    "DoorZone",
    "Doorway",
    "House",
    "HouseFloor",
    "HouseWalkable",
    "blocked_windows",
    "cut_off_doors",
    "door_blockers",
    "door_zones",
    "house_walkable",
    "wall_crossings",
]

DOOR_CLEARANCE_DEPTH_M = 0.6
"""Depth (metres) of the zone kept clear in front of a door, on each side, as wide as the door.
0.6 m lets a robot of ``ROBOT_RADIUS`` (0.4 m across) come through square and turn, and a door
leaf up to about that wide swing; AI2-THOR's doors name no hinge side, so the zone is not a
quarter circle but the rectangle that holds either swing's first 0.6 m."""
DOOR_MATCH_TOLERANCE_M = 0.03
"""Two rooms' doors are one doorway when their centres, seen through the wall between them, lie
this close (metres) and their widths agree as closely."""
MIN_PASSAGE_M = 0.5
"""Two rooms' cuts that overlap less than this along the wall (metres) are not one doorway."""
HOUSE_CELL_M = 0.05
"""Cell side (metres) of the house-wide walkable raster (a 15 m house: 300 cells)."""
WALL_CROSSING_TOLERANCE_M = 0.01
"""How far (metres) an object's footprint may reach past its room's floor before it counts as
crossing a wall: a picture hung on a wall touches the wall's face, and float noise is allowed."""


class House(_Model):
    """A house: one scene per room, all in one world frame, in the source's room order."""

    id: str = "house"
    rooms: list[Scene] = Field(min_length=1)
    metadata: dict[str, Any] = Field(default_factory=dict)
    provenance: Provenance = Field(default_factory=Provenance)

    @field_validator("rooms")
    @classmethod
    def _distinct(cls, v: list[Scene]) -> list[Scene]:
        seen: set[str] = set()
        ids: set[str] = set()
        for s in v:
            if s.room is None:
                raise ValueError(f"room scene {s.id!r} has no room")
            if s.id in seen:
                raise ValueError(f"two rooms share the id {s.id!r}")
            seen.add(s.id)
            clash = ids & {o.id for o in s.objects}
            if clash:
                raise ValueError(f"object id(s) {sorted(clash)[:3]} appear in two rooms")
            ids |= {o.id for o in s.objects}
        floors = [pt for s in v if s.room is not None for pt in s.room.floor]
        problem = house_problem(len(v), (pt[0] for pt in floors), (pt[1] for pt in floors))
        if problem is not None:
            raise ValueError(f"the house is too large: {problem}")
        return v

    @property
    def objects(self) -> list[SceneObject]:
        """Every object of every room, room by room."""
        return [o for s in self.rooms for o in s.objects]

    @property
    def room_ids(self) -> list[str]:
        """The rooms' ids, in the house's order."""
        return [s.id for s in self.rooms]

    def room(self, room_id: str) -> Scene:
        """The scene of one room, by its id (or, for an imported house, its source id such as
        ProcTHOR's ``room|4``); raises ``KeyError`` naming the rooms."""
        for s in self.rooms:
            source = s.provenance.source_room_id
            if room_id in (s.id, source, s.room.id if s.room else None):
                return s
        raise KeyError(f"no room {room_id!r}; the house has {', '.join(self.room_ids)}")

    def room_of(self, object_id: str) -> Scene:
        """The room scene holding ``object_id``."""
        for s in self.rooms:
            if any(o.id == object_id for o in s.objects):
                return s
        raise KeyError(object_id)

    def __repr_args__(self) -> Iterator[tuple[str | None, Any]]:
        """``repr``, ``str`` (and rich) show the id, the room ids and the object count, not every
        room's full model (``model_dump`` gives that)."""
        yield "id", self.id
        yield "rooms", self.room_ids
        yield "objects", len(self.objects)

    def _repr_png_(self) -> bytes | None:
        """Jupyter shows the house's plan, every room named (the renderer registered with
        :func:`~scenemosaic.scene.register_plan_renderer`); ``None`` (the text repr) when none is
        registered or the plan cannot be drawn."""
        return _plan_png(self)

    def with_rooms(self, rooms: Sequence[Scene]) -> House:
        """This house with its room scenes replaced (same ids, same order)."""
        return self.model_copy(update={"rooms": list(rooms)})

    def doorways(self) -> list[Doorway]:
        """Every door and open stretch of wall between rooms, once.

        A door (or ``opening``) cut into two rooms' walls at the same place — the walls' faces
        run opposite ways, lie at most a wall's thickness (plus :data:`DOOR_MATCH_TOLERANCE_M`)
        apart, and the two cuts overlap along the wall — is one doorway joining the rooms, as
        wide as the overlap (each cut only as wide as its wall: :meth:`Wall.span`); a cut into a
        single room's wall leads outside (``rooms`` has one id).
        """
        cuts = [(s.id, w, op) for s in self.rooms for w in _walls(s) for op in w.openings if op.kind != "window"]
        used: set[int] = set()
        out: list[Doorway] = []
        for i, (rid, wall, op) in enumerate(cuts):
            if i in used:
                continue
            used.add(i)
            lo, hi = wall.span(op)
            width = hi - lo
            sides = [(rid, wall)]
            for j in range(i + 1, len(cuts)):
                rj, wj, oj = cuts[j]
                if j in used or rj == rid or (oj.kind == "door") != (op.kind == "door"):
                    continue
                if float(np.dot(wall.direction, wj.direction)) > -0.99:
                    continue  # the two faces of one wall run opposite ways
                cj = _opening_centre(wj, oj)
                through = float(np.dot(cj - np.asarray(wall.start), wall.outward_normal))
                if not -DOOR_MATCH_TOLERANCE_M <= through <= wall.thickness + DOOR_MATCH_TOLERANCE_M:
                    continue
                jlo, jhi = sorted(  # its span, clipped to its wall, measured along this wall
                    float(np.dot(np.asarray(wj.start) + wj.direction * t - np.asarray(wall.start), wall.direction))
                    for t in wj.span(oj)
                )
                olo, ohi = max(lo, jlo), min(hi, jhi)
                if ohi - olo < min(width, jhi - jlo) - 2 * DOOR_MATCH_TOLERANCE_M and ohi - olo < MIN_PASSAGE_M:
                    continue
                lo, hi = olo, ohi
                sides.append((rj, wj))
                used.add(j)
                break
            a = np.asarray(wall.start, dtype=np.float64) + wall.direction * ((lo + hi) / 2)
            faces = [DoorSide(rid, wall.id, a)]
            if len(sides) > 1:
                rj, wj = sides[1]
                b = a + wall.outward_normal * abs(float(np.dot(a - np.asarray(wj.start), wj.inward_normal)))
                faces.append(DoorSide(rj, wj.id, b))
            out.append(
                Doorway(
                    id=f"{op.kind}_{len(out)}", kind=op.kind, width=hi - lo, height=op.bottom + op.height,
                    sides=tuple(faces), direction=wall.direction.copy(), normal=wall.outward_normal.copy(),
                )
            )  # fmt: skip
        return out


def _walls(scene: Scene) -> list[Wall]:
    return scene.room.walls if scene.room is not None else []


def _opening_centre(wall: Wall, op: Opening) -> FloatArray:
    out: FloatArray = np.asarray(wall.start, dtype=np.float64) + wall.direction * op.center
    return out


@dataclass(frozen=True)
class DoorSide:
    """One room's face of a doorway: the room, its wall, the door's centre on that wall's line."""

    room_id: str
    wall_id: str
    centre: FloatArray


@dataclass(frozen=True)
class Doorway:
    """A door (or open doorway) between two rooms, or from one room to the outside."""

    id: str
    kind: str
    width: float
    height: float
    sides: tuple[DoorSide, ...]
    direction: FloatArray
    """Unit vector along the wall (of the first side's wall)."""
    normal: FloatArray
    """Unit vector through the wall, out of the first side's room."""

    @property
    def rooms(self) -> tuple[str, ...]:
        """The ids of the rooms it joins (one: a door to the outside)."""
        return tuple(s.room_id for s in self.sides)

    @property
    def leads_outside(self) -> bool:
        """Whether it opens from one room to the outside."""
        return len(self.sides) == 1

    def passage(self, reach: float = 0.0) -> Polygon:
        """The hole through the wall: as wide as the door, from one room's floor edge to the
        other's (just the first side's wall line for a door to the outside).

        ``reach`` (metres, default 0) extends it that far past both floor edges, into the rooms,
        still as wide as the door: the reachability raster's passage (:func:`house_walkable`),
        which then overlaps both floors whatever the cells' offset."""
        a = self.sides[0].centre - self.normal * reach
        b = (self.sides[-1].centre if len(self.sides) > 1 else self.sides[0].centre) + self.normal * reach
        half = self.direction * (self.width / 2)
        pts = [a - half, a + half, b + half, b - half]
        poly = Polygon([tuple(p) for p in pts])
        return poly if poly.area > 0 else Polygon([tuple(p) for p in pts]).buffer(1e-3)


@dataclass(frozen=True)
class DoorZone:
    """The clearance zone in front of one side of a doorway, inside that side's room."""

    door_id: str
    room_id: str
    polygon: Polygon
    height: float


DOOR_ZONE_ROOM_LEFT_M = 1.2
"""A door's zone as deep as the door is wide (``door_zones(..., depth=None)``) leaves at least this
much of the room beyond it (metres, along the door's normal to the far wall): a narrow room (a
1.8 m wide living room with a double door along it) keeps :data:`DOOR_CLEARANCE_DEPTH_M`, else its
furniture would have nowhere to go."""


def _swing_depth(floor: Polygon, centre: FloatArray, inward: FloatArray, width: float) -> float:
    """How deep the zone of a door ``width`` wide is when it reaches as deep as the door is wide:
    that, but no deeper than leaves :data:`DOOR_ZONE_ROOM_LEFT_M` of the room before the far wall,
    and never shallower than :data:`DOOR_CLEARANCE_DEPTH_M`."""
    from shapely.geometry import LineString

    ray = LineString([tuple(centre + inward * 1e-3), tuple(centre + inward * 100.0)]).intersection(floor)
    parts = getattr(ray, "geoms", [ray])
    room = min((float(p.length) for p in parts if not p.is_empty), default=0.0) + 1e-3
    return max(DOOR_CLEARANCE_DEPTH_M, min(width, room - DOOR_ZONE_ROOM_LEFT_M))


def door_zones(
    house: House | Scene, depth: float | None = DOOR_CLEARANCE_DEPTH_M, kinds: tuple[str, ...] = ("door",)
) -> list[DoorZone]:
    """The clearance zone of every door on every side it opens onto: a rectangle as wide as the
    door, ``depth`` deep from the wall's face into the room (``None``: as deep as the door is wide,
    where its leaves swing and how far SceneEval's Opening Clearance looks, but leaving
    :data:`DOOR_ZONE_ROOM_LEFT_M` of the room beyond it, and at least :data:`DOOR_CLEARANCE_DEPTH_M`),
    clipped to the room's floor. An open
    stretch of wall (kind ``opening``: open-plan rooms) is no door and has no zone; reachability
    (:func:`house_walkable`) covers it. ``kinds=("opening",)`` gives the same rectangles in front
    of the open stretches instead (the evolution keeps them reachable).

    A single room (a :class:`Scene`) gives the zones of the doors cut into its own walls.
    """
    scenes = house.rooms if isinstance(house, House) else [house]
    out: list[DoorZone] = []
    for scene in scenes:
        if scene.room is None:
            continue
        floor = Polygon(scene.room.floor)
        k = 0
        for wall in scene.room.walls:
            for op in wall.openings:
                if op.kind not in kinds:
                    continue
                c = _opening_centre(wall, op)
                deep = _swing_depth(floor, c, wall.inward_normal, op.width) if depth is None else depth
                half, inward = wall.direction * (op.width / 2), wall.inward_normal * deep
                rect = Polygon([tuple(c - half), tuple(c + half), tuple(c + half + inward), tuple(c - half + inward)])
                zone = rect.intersection(floor)
                if not zone.is_empty:
                    out.append(DoorZone(f"{scene.id}:{wall.id}:{k}", scene.id, zone, op.bottom + op.height))
                k += 1
    return out


@dataclass(frozen=True)
class DoorBlock:
    """An object standing in a door's clearance zone."""

    door: str
    room_id: str
    object_id: str
    area_m2: float


def _blocks_walking(obj: SceneObject, below: float) -> bool:
    """Whether a robot walking there runs into ``obj``: its bottom is below ``below`` and it is not
    thin (a rug is walked over)."""
    return float(obj.aabb()[0][2]) < below and not is_thin(obj)


def door_blockers(
    house: House | Scene, *, depth: float = DOOR_CLEARANCE_DEPTH_M, min_area_m2: float = 1e-4
) -> list[DoorBlock]:
    """Every object whose footprint overlaps a door's clearance zone (:func:`door_zones`) by more
    than ``min_area_m2`` and whose bottom is below the door's top and below ``WALK_MAX_HEIGHT``
    (a lamp hung above the zone is walked under)."""
    scenes = house.rooms if isinstance(house, House) else [house]
    by_room = {s.id: s for s in scenes}
    out: list[DoorBlock] = []
    for zone in door_zones(house, depth):
        for obj in by_room[zone.room_id].objects:
            if not _blocks_walking(obj, min(zone.height, WALK_MAX_HEIGHT)):
                continue
            area = Polygon(convex_hull_2d(obj.corners()[:, :2])).intersection(zone.polygon).area
            if area > min_area_m2:
                out.append(DoorBlock(zone.door_id, zone.room_id, obj.id, float(area)))
    return out


def cut_off_doors(scene: Scene, *, depth: float = DOOR_CLEARANCE_DEPTH_M, radius: float = ROBOT_RADIUS,
                  cell: float = HOUSE_CELL_M) -> list[str]:  # fmt: skip
    """The doors of a room a robot standing in their clearance zone cannot leave by: the zone
    holds no free cell of the room's largest walkable piece (the room's own raster: its floor,
    what stands on it, eroded by ``radius``). A door behind a bed, or in a pocket a chair closes,
    is cut off even when nothing stands in its zone."""
    zones = door_zones(scene, depth)
    if not zones or scene.room is None:
        return []
    raster = FloorRaster(np.asarray(scene.room.floor, dtype=np.float64), cell=cell)
    feet = [convex_hull_2d(o.corners()[:, :2]) for o in scene.objects if _blocks_walking(o, WALK_MAX_HEIGHT)]
    walk = raster.walkable(raster.blocked(feet), radius)
    main = walk.labels == walk.main
    # the zone grown by the robot's radius: a robot centred at its edge still stands in front of the door
    return [z.door_id for z in zones if not bool((main & raster.mask(z.polygon.buffer(radius))).any())]


def wall_crossings(house: House | Scene, tolerance: float = WALL_CROSSING_TOLERANCE_M) -> list[tuple[str, str, float]]:
    """``(room id, object id, metres past the floor)`` for every object whose box footprint reaches
    more than ``tolerance`` beyond its room's floor polygon: into a wall, or through it."""
    scenes = house.rooms if isinstance(house, House) else [house]
    out: list[tuple[str, str, float]] = []
    for scene in scenes:
        if scene.room is None:
            continue
        floor = Polygon(scene.room.floor)
        grown = floor.buffer(tolerance, join_style="mitre")
        for obj in scene.objects:
            foot = Polygon(convex_hull_2d(obj.corners()[:, :2]))
            if not grown.covers(foot):
                out.append((scene.id, obj.id, round(_reach_past(floor, foot), 4)))
    return out


def _reach_past(floor: Polygon, foot: Polygon, samples: int = 8) -> float:
    """The farthest the footprint reaches outside the floor, metres: the part of it outside,
    sampled along its outline (a footprint that clips a room's inner corner has its corners on
    the floor's edge and reaches out between them)."""
    outside = foot.difference(floor)
    if outside.is_empty:
        return 0.0
    far = 0.0
    for piece in getattr(outside, "geoms", [outside]):
        ring = np.asarray(getattr(piece, "exterior", piece).coords, dtype=np.float64)
        for a, b in itertools.pairwise(ring):
            for t in np.linspace(0.0, 1.0, samples + 1):
                far = max(far, floor.distance(Point(*(a + (b - a) * t))))
    return far


@dataclass(frozen=True)
class HouseWalkable:
    """The house-wide walkable raster, split into pieces, and what it says per room."""

    walkable: Walkable
    raster: FloorRaster
    room_cells: dict[str, np.ndarray]
    """Per room: its floor's cells."""

    @property
    def nav(self) -> float:
        """House NAV: the largest connected piece of walkable floor over all of it."""
        return self.walkable.share

    def reached(self) -> dict[str, float]:
        """Per room: the share of its walkable cells that lie in the house's largest piece (1.0:
        all of the room's free floor is reachable from the rest of the house)."""
        main = self.walkable.labels == self.walkable.main
        out = {}
        for rid, cells in self.room_cells.items():
            free = int((self.walkable.free & cells).sum())
            out[rid] = float((main & cells).sum()) / free if free else 0.0
        return out

    def unreachable_rooms(self) -> list[str]:
        """Rooms no cell of the house's largest walkable piece enters."""
        main = self.walkable.labels == self.walkable.main
        return [rid for rid, cells in self.room_cells.items() if not bool((main & cells).any())]


def house_walkable(house: House, *, radius: float = ROBOT_RADIUS, cell: float = HOUSE_CELL_M) -> HouseWalkable:
    """One walkable raster over the whole house: every room's floor and every doorway's passage
    through its wall are floor; each object whose bottom is below ``WALK_MAX_HEIGHT`` blocks its
    box footprint; the free cells are eroded by a disk of ``radius`` and split into 4-connected
    pieces (the same definition as a room's NAV, :class:`FloorRaster`).

    The answer does not hang on where the cells fall (the cells lie on the world's grid of
    ``cell`` metres, so a house moved by part of a cell meets them elsewhere):

    * a doorway's passage reaches a cell past both floor edges (``Doorway.passage(reach=cell)``),
      so the cells along the edges, whose centres lie on neither floor, still join the rooms;
    * where two rooms' floor cells meet outside every passage (floors that touch with no wall
      between them), both cells are wall: rooms join only through their doorways.

    To judge many arrangements of one house's rooms, build a :class:`HouseFloor` once.
    """
    return HouseFloor(house, radius=radius, cell=cell).walkable(house.rooms)


class HouseFloor:
    """A house's walkable raster without its furniture (floors, passages, the seams between
    rooms), built once, and :meth:`walkable` for any arrangement of its rooms' objects: the same
    answer as :func:`house_walkable` of the house with those rooms. Each room scene's blocked cells
    are kept, by the scene's identity, for as long as the floor lives, so candidates that share a
    room's arrangement (a house's composition tries many) rasterize it once: a room scene changed
    in place after it was asked about must be passed as a new scene (``model_copy``)."""

    def __init__(self, house: House, *, radius: float = ROBOT_RADIUS, cell: float = HOUSE_CELL_M) -> None:
        shells = tuple((s.id, s.room.model_dump_json() if s.room is not None else "") for s in house.rooms)
        self.raster, self.room_cells = _HOUSE_RASTERS.get((shells, cell), lambda: _house_raster(house, cell))
        self.radius = radius
        self._blocked: dict[int, tuple[Scene, np.ndarray]] = {}

    def _room_blocked(self, room: Scene) -> np.ndarray:
        known = self._blocked.get(id(room))
        if known is not None and known[0] is room:
            return known[1]
        footprints = [convex_hull_2d(o.corners()[:, :2]) for o in room.objects if _blocks_walking(o, WALK_MAX_HEIGHT)]
        mask = self.raster.blocked(footprints)
        self._blocked[id(room)] = (room, mask)  # the scene held with its mask: its id is not reused meanwhile
        return mask

    def walkable(self, rooms: Sequence[Scene]) -> HouseWalkable:
        """The house's walkable raster with ``rooms`` (the house's room scenes, in any arrangement)."""
        blocked = np.zeros(self.raster.shape, dtype=bool)
        for room in rooms:
            blocked |= self._room_blocked(room)
        return HouseWalkable(self.raster.walkable(blocked, self.radius), self.raster, self.room_cells)

    def keeps(self, base: Sequence[Scene]) -> Callable[[Sequence[Scene]], bool]:
        """A test of other arrangements of the house's rooms against the ``base`` arrangement:
        every room the base reaches still reached, and the house's largest walkable piece (its NAV
        over every floor and doorway) holding :func:`~scenemosaic.scene.kept_floor_share` of the
        base's, so a variant never cuts off floor the base leaves open (a wardrobe turned across
        a room's corner keeps every door reachable and still walls off a strip of floor)."""
        walk = self.walkable(base)
        unreachable, least = set(walk.unreachable_rooms()), kept_floor_share(walk.nav)

        def test(rooms: Sequence[Scene]) -> bool:
            now = self.walkable(rooms)
            return set(now.unreachable_rooms()) <= unreachable and now.nav >= least

        return test


def _house_raster(house: House, cell: float) -> tuple[FloorRaster, dict[str, np.ndarray]]:
    """The raster of a house's floors and passages without furniture (the seams between rooms
    closed), and each room's floor cells: what :class:`HouseFloor` starts from."""
    rooms = [s for s in house.rooms if s.room is not None]
    floors = [Polygon(s.room.floor) for s in rooms if s.room is not None]
    passages = [d.passage(reach=cell) for d in house.doorways() if not d.leads_outside]
    minx, miny, maxx, maxy = unary_union([*floors, *passages]).bounds
    minx, miny = np.floor(minx / cell) * cell, np.floor(miny / cell) * cell
    raster = FloorRaster(np.array([[minx, miny], [maxx, miny], [maxx, maxy], [minx, maxy]]), cell=cell)
    owner = np.zeros(raster.shape, dtype=np.int64)  # 1 + the index of the room whose floor holds the cell
    room_cells: dict[str, np.ndarray] = {}
    for k, (s, poly) in enumerate(zip(rooms, floors, strict=True)):
        cells = raster.mask(poly)
        cells.flags.writeable = False
        room_cells[s.id] = cells
        owner[cells] = k + 1
    through = raster.blocked(passages)
    raster.inside = ((owner > 0) | through) & ~_seams(owner, through)
    return raster, room_cells


_HOUSE_RASTERS: Memo[tuple[tuple[tuple[str, str], ...], float], tuple[FloorRaster, dict[str, np.ndarray]]] = Memo(16)
"""House rasters by the rooms' shells and the cell size: a house's variants (compose, validate,
evaluate) share them. Shared: never modified."""


def _seams(owner: np.ndarray, through: np.ndarray) -> np.ndarray:
    """The cells of two rooms' floors that are 4-neighbours with neither in a passage: the line
    where two floors touch with no doorway, which the robot may not cross."""
    out = np.zeros(owner.shape, dtype=bool)
    for axis in (0, 1):
        lo = [slice(None), slice(None)]
        hi = [slice(None), slice(None)]
        lo[axis], hi[axis] = slice(None, -1), slice(1, None)
        a, b = owner[tuple(lo)], owner[tuple(hi)]
        meet = (a > 0) & (b > 0) & (a != b) & ~through[tuple(lo)] & ~through[tuple(hi)]
        out[tuple(lo)] |= meet
        out[tuple(hi)] |= meet
    return out


WINDOW_REACH_M = 0.5
"""A piece whose footprint comes this near a window's stretch of wall stands before it (SceneEval's
Opening Clearance looks as far in front of a window: its ``window_front_extrude_distance``)."""


def blocked_windows(scene: Scene) -> dict[str, list[str]]:
    """The windows of ``scene``'s walls that furniture stands before, by ``<wall id>/window_<k>`` (``k``
    counting the wall's openings), each with the pieces (object ids of floor pieces): a piece on the
    floor, or something it carries (a TV on its stand, a plant on a table), whose top rises above
    the window's sill and whose footprint comes within :data:`WINDOW_REACH_M` of the window's
    stretch of wall (a wardrobe backed against it, a TV on a low stand before it; a low bench
    beneath it, with nothing tall on it, does not block)."""
    from shapely.geometry import LineString

    if scene.room is None:
        return {}
    tall = [(o, scene.floor_root(o.id)) for o in scene.objects]
    out: dict[str, list[str]] = {}
    for wall in scene.room.walls:
        start, direction = np.asarray(wall.start, dtype=np.float64), np.asarray(wall.direction, dtype=np.float64)
        for k, op in enumerate(wall.openings):
            if op.kind != "window":
                continue
            lo, hi = wall.span(op)
            span = LineString([start + direction * lo, start + direction * hi])
            found = sorted({
                root for o, root in tall
                if root is not None and float(o.aabb()[1][2]) > op.bottom + 1e-3
                and Polygon(o.footprint()).distance(span) <= WINDOW_REACH_M
            })  # fmt: skip
            if found:
                out[f"{wall.id}/window_{k}"] = found
    return out
