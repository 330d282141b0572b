"""Issue 38: what is derived from an asset is worked out once per process and shared.

A house's variants hold the same furniture at other poses: its collision shape, its hull meshes
and its exported files are keyed by the asset's fingerprint (or the vertices' hash), so the
second variant costs no geometry work, and what a memo hands out equals what fresh work gives.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from scenemosaic._memo import Memo
from scenemosaic.assets import asset_fingerprint
from scenemosaic.physics import hull_mesh, object_shape
from scenemosaic.physics._hulls import _hull_arrays
from scenemosaic.scene import AssetRef, Pose, SceneObject


def _chest(
    oid: str, xy: tuple[float, float], extents: tuple[float, float, float] = (0.8, 0.45, 0.9)
) -> SceneObject:
    return SceneObject(
        id=oid,
        category="dresser",
        asset=AssetRef(kind="procedural", category="dresser", extents=extents),
        pose=Pose.from_yaw((xy[0], xy[1], 0.0), 30.0 * xy[0]),
    )


def test_a_memo_makes_each_value_once_and_drops_the_oldest_when_full() -> None:
    memo: Memo[str, list[str]] = Memo(2)
    made: list[str] = []

    def make(key: str) -> list[str]:
        made.append(key)
        return [key]

    first = memo.get("a", lambda: make("a"))
    assert memo.get("a", lambda: make("a")) is first  # shared, not made again
    memo.get("b", lambda: make("b"))
    memo.get("c", lambda: make("c"))  # full: "a" goes
    assert len(memo) == 2
    memo.get("a", lambda: make("a"))
    assert made == ["a", "b", "c", "a"]
    with pytest.raises(ValueError, match="at least one"):
        Memo(0)


def test_the_fingerprint_follows_the_geometry_not_the_pose_or_the_id() -> None:
    here, there = _chest("a", (1.0, 1.0)), _chest("b", (3.0, 2.0))
    assert asset_fingerprint(here) == asset_fingerprint(there)
    assert asset_fingerprint(here) != asset_fingerprint(_chest("a", (1.0, 1.0), (0.8, 0.45, 1.0)))
    relabelled = here.model_copy(update={"category": "nightstand"})  # the procedural model is the asset's own
    assert asset_fingerprint(relabelled) != asset_fingerprint(here)


def test_a_mesh_asset_is_known_by_its_content_wherever_its_folder_is(tmp_path: Path) -> None:
    one, two = tmp_path / "one", tmp_path / "two"
    one.mkdir()
    trimesh.creation.box(extents=(1.0, 0.5, 0.4)).export(one / "box.obj")
    shutil.copytree(one, two)

    def obj(folder: Path) -> SceneObject:
        return SceneObject(
            id="thing",
            category="box",
            asset=AssetRef(kind="mesh", uri="box.obj", extents=(1.0, 0.5, 0.4)),
            pose=Pose.from_yaw((0.0, 0.0, 0.0), 0.0),
        )

    assert asset_fingerprint(obj(one), one) == asset_fingerprint(obj(two), two)
    trimesh.creation.box(extents=(1.0, 0.5, 0.5)).export(two / "box.obj")  # another mesh under the same name
    assert asset_fingerprint(obj(one), one) != asset_fingerprint(obj(two), two)


def test_two_poses_of_one_asset_share_one_shape_and_given_pieces_do_not() -> None:
    a, b = _chest("a", (1.0, 1.0)), _chest("b", (2.5, 0.5))
    shape = object_shape(a)
    assert object_shape(b) is shape  # nothing worked out again
    assert shape.articulation  # a dresser's drawers come with it
    own = [p.vertices for p in shape.pieces]
    given = object_shape(a, hulls={"a": own})
    assert given is not shape and len(given.pieces) == len(shape.pieces)
    assert given.articulation == shape.articulation  # the asset's own pieces: its drawers still move
    one_box = object_shape(a, hulls={"a": [np.vstack(own)]})
    assert one_box.articulation == ()  # pieces that are not the asset's own: nothing says which move


points = st.lists(
    st.tuples(*(st.floats(-2.0, 2.0, allow_nan=False, width=32) for _ in range(3))),
    min_size=5,
    max_size=40,
    unique=True,
)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(points)
def test_hull_meshes_are_trimesh_hulls(cloud: list[tuple[float, float, float]]) -> None:
    """The hull of distinct points is the one ``trimesh`` builds: same vertices, same triangles."""
    pts = np.asarray(cloud, dtype=np.float64)
    try:
        expected = trimesh.Trimesh(vertices=pts).convex_hull
    except Exception:  # flat sets: trimesh's own retry decides; not what the fast path serves
        return
    vertices, faces = _hull_arrays(pts)
    if len(np.unique(np.round(pts, 8), axis=0)) == len(pts) and expected.is_volume:
        assert np.array_equal(vertices, expected.vertices)
        assert np.array_equal(faces, expected.faces)
    mesh = hull_mesh(pts)
    assert mesh.is_watertight or not expected.is_watertight
    mesh.vertices[:] = 0.0  # a fresh copy: the memo keeps its own
    assert np.array_equal(hull_mesh(pts).vertices, vertices)
