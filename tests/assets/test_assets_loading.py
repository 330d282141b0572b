"""load_mesh on real SAM3D glTFs and on broken files; mesh_hash stability."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from scenemosaic.assets import load_mesh, mesh_hash
from scenemosaic.assets._canonical import _load_cached, load_source_mesh
from scenemosaic.exceptions import AssetError

# ``tests/conftest.py``'s DATA, found the same way (test folders are not packages)
ASSETS = Path(__file__).resolve().parents[2] / "data" / "sam3d_objects" / "generated_assets"
KING_BED = ASSETS / "sdf" / "king_bed_1761578419" / "king_bed.gltf"
WORK_DESK = ASSETS / "sdf" / "work_desk_1761578426" / "work_desk.gltf"
OFFICE_CHAIR = ASSETS / "sdf" / "office_chair_1761578426" / "office_chair.gltf"
PRINTER = ASSETS / "sdf" / "printer_1761578426" / "printer.gltf"
COFFEE_MUG = ASSETS / "manipulands" / "sdf" / "coffee_mug_1762992163" / "coffee_mug.gltf"


def test_repo_data_is_where_conftest_says(repo_data: Path) -> None:
    assert ASSETS.resolve().is_relative_to(repo_data)
    assert COFFEE_MUG.is_file()


@pytest.mark.parametrize(
    "path", [KING_BED, WORK_DESK, OFFICE_CHAIR, PRINTER, COFFEE_MUG], ids=lambda p: p.stem
)
def test_sam3d_gltf_is_canonical(path: Path) -> None:
    canonical = load_mesh(path)
    lo, hi = canonical.mesh.bounds
    assert lo[2] == pytest.approx(0.0, abs=1e-9)
    assert (lo[0] + hi[0]) / 2 == pytest.approx(0.0, abs=1e-9)
    assert (lo[1] + hi[1]) / 2 == pytest.approx(0.0, abs=1e-9)
    np.testing.assert_allclose(canonical.extents, hi - lo, atol=1e-12)
    # the recorded transform reproduces the canonical mesh from the file's coordinates
    source = np.asarray(load_source_mesh(path).vertices)
    moved = source @ canonical.transform[:3, :3].T + canonical.transform[:3, 3]
    np.testing.assert_allclose(moved, canonical.mesh.vertices, atol=1e-9)
    # a proper rotation (no mirroring) with unit scale
    assert np.linalg.det(canonical.transform[:3, :3]) == pytest.approx(1.0)


@pytest.mark.parametrize("path", [KING_BED, WORK_DESK], ids=lambda p: p.stem)
def test_furniture_comes_out_wider_than_tall(path: Path) -> None:
    w, d, h = load_mesh(path).extents
    assert max(w, d) > h


def test_mug_is_about_as_tall_as_wide() -> None:
    w, d, h = load_mesh(COFFEE_MUG).extents
    assert 0.6 < h / max(w, d) < 1.4
    assert 0.05 < h < 0.2  # metres: a mug, not a bucket


def test_gltf_y_up_becomes_z_up_and_plus_z_front_becomes_minus_y(tmp_path: Path) -> None:
    # A tall post (1 m along glTF's up axis +Y) with a knob toward glTF's front (+Z).
    post = trimesh.creation.box(bounds=[[-0.1, 0.0, -0.1], [0.1, 1.0, 0.1]])
    knob = trimesh.creation.box(bounds=[[-0.05, 0.4, 0.1], [0.05, 0.5, 0.4]])
    path = tmp_path / "post.glb"
    trimesh.Scene([post, knob]).export(path)
    canonical = load_mesh(path)
    w, d, h = canonical.extents
    assert h == pytest.approx(1.0)
    assert (w, d) == pytest.approx((0.2, 0.5))
    # the knob sticks out toward -Y, our front: the front-most vertices are the knob's
    vertices = canonical.mesh.vertices
    front = vertices[vertices[:, 1] < vertices[:, 1].min() + 1e-9]
    assert np.all((front[:, 2] > 0.4 - 1e-9) & (front[:, 2] < 0.5 + 1e-9))
    post_only = vertices[(vertices[:, 2] < 0.4 - 1e-9) | (vertices[:, 2] > 0.5 + 1e-9)]
    assert post_only[:, 1].min() == pytest.approx(vertices[:, 1].min() + 0.3)  # the knob is 0.3 m in front


def test_scene_nodes_are_concatenated_with_their_transforms(tmp_path: Path) -> None:
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box(extents=(1.0, 1.0, 1.0)), node_name="a")
    moved = np.eye(4)
    moved[:3, 3] = (3.0, 0.0, 0.0)
    scene.add_geometry(trimesh.creation.box(extents=(1.0, 1.0, 1.0)), node_name="b", transform=moved)
    path = tmp_path / "two.glb"
    scene.export(path)
    canonical = load_mesh(path)
    assert canonical.extents == pytest.approx((4.0, 1.0, 1.0))
    assert len(canonical.mesh.faces) == 24


def test_up_axis_override_and_unit_scale(tmp_path: Path) -> None:
    path = tmp_path / "slab.obj"
    trimesh.creation.box(bounds=[[0.0, 0.0, 0.0], [200.0, 100.0, 50.0]]).export(path)
    as_z = load_mesh(path, unit_scale=0.01)  # OBJ: z up by default
    assert as_z.extents == pytest.approx((2.0, 1.0, 0.5))
    as_y = load_mesh(path, up_axis="y", unit_scale=0.01)
    assert as_y.extents == pytest.approx((2.0, 0.5, 1.0))
    assert as_y.sha256 != as_z.sha256


def test_hash_is_stable_across_loads_and_sensitive_to_geometry() -> None:
    first = load_mesh(COFFEE_MUG)
    _load_cached.cache_clear()  # parse the file again, not the in-process copy
    second = load_mesh(COFFEE_MUG)
    assert first.mesh is not second.mesh
    assert first.sha256 == second.sha256 == mesh_hash(second.mesh)
    assert len(first.sha256) == 64
    geometry_only = trimesh.Trimesh(second.mesh.vertices, second.mesh.faces, process=False)
    assert mesh_hash(geometry_only) == first.sha256  # visuals (UVs, texture) are not hashed
    moved = second.mesh.copy()
    moved.vertices = moved.vertices + np.array([1e-3, 0.0, 0.0])
    assert mesh_hash(moved) != first.sha256
    assert load_mesh(PRINTER).sha256 != first.sha256


def test_hash_ignores_float_noise_below_the_rounding_step() -> None:
    box = trimesh.creation.box(extents=(1.0, 2.0, 0.5))
    noisy = box.copy()
    noisy.vertices = noisy.vertices + np.random.default_rng(0).uniform(-1e-8, 1e-8, noisy.vertices.shape)
    assert mesh_hash(noisy) == mesh_hash(box)
    flipped_zero = trimesh.Trimesh(
        [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 1.0]], [[0, 1, 2]], process=False
    )
    negative_zero = trimesh.Trimesh(
        [[-0.0, -0.0, 0.0], [1.0, -0.0, 0.0], [0.0, 1.0, 1.0]], [[0, 1, 2]], process=False
    )
    assert mesh_hash(flipped_zero) == mesh_hash(negative_zero)


def test_loaded_mesh_is_a_private_copy() -> None:
    first = load_mesh(PRINTER)
    first.mesh.apply_translation((10.0, 0.0, 0.0))
    again = load_mesh(PRINTER)
    assert again.mesh.bounds[0][2] == pytest.approx(0.0)
    assert abs(again.mesh.centroid[0]) < 1.0


def _assert_names(exc: pytest.ExceptionInfo[AssetError], path: Path) -> None:
    assert path.name in str(exc.value)


def test_missing_file(tmp_path: Path) -> None:
    path = tmp_path / "nope.glb"
    with pytest.raises(AssetError) as exc:
        load_mesh(path)
    _assert_names(exc, path)


@pytest.mark.parametrize("suffix", [".glb", ".gltf", ".obj", ".ply"])
def test_garbage_bytes(tmp_path: Path, suffix: str) -> None:
    path = tmp_path / f"garbage{suffix}"
    path.write_bytes(bytes(range(256)) * 8)
    with pytest.raises(AssetError) as exc:
        load_mesh(path)
    _assert_names(exc, path)


@pytest.mark.parametrize(
    ("name", "obj_text"),
    [
        ("flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\n"),  # zero area
        ("needles.obj", "v 0 0 0\nv 1 1 1\nv 2 2 2\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 4 4 5\n"),  # collinear in 3D
        ("points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 1\n"),  # no faces
        ("nan.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv nan 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\n"),  # NaN vertex
    ],
    ids=["zero_area", "collinear_faces", "no_faces", "nan_vertices"],
)
def test_degenerate_mesh_is_an_error_naming_the_file(tmp_path: Path, name: str, obj_text: str) -> None:
    path = tmp_path / name
    path.write_text(obj_text)
    with pytest.raises(AssetError) as exc:
        load_mesh(path)
    _assert_names(exc, path)


def test_bad_unit_scale() -> None:
    with pytest.raises(AssetError):
        load_mesh(COFFEE_MUG, unit_scale=0.0)
