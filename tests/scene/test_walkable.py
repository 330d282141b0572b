"""The walkable-floor raster that NAV and the layout critic share, on floors worked out by hand."""

from __future__ import annotations

import numpy as np
import pytest

from scenemosaic.scene import ROBOT_RADIUS, WALK_GRID, FloorRaster

FLOOR = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 2.0], [0.0, 2.0]])


def _box(x0: float, y0: float, x1: float, y1: float) -> np.ndarray:
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])


def test_the_raster_covers_the_floor_with_the_nav_grid() -> None:
    raster = FloorRaster(FLOOR)
    assert raster.shape == (WALK_GRID, WALK_GRID // 2)
    assert raster.cell == pytest.approx(4.0 / WALK_GRID)
    assert raster.inside.all()
    walk = raster.walkable(raster.blocked([]))
    assert len(walk.sizes) == 1 and walk.share == 1.0
    # eroded by the robot: a 0.2 m margin all round is not free
    side = 4.0 - 2 * ROBOT_RADIUS, 2.0 - 2 * ROBOT_RADIUS
    assert walk.total * raster.cell**2 == pytest.approx(side[0] * side[1], rel=0.03)


def test_a_gap_narrower_than_the_robot_cuts_the_floor_in_two() -> None:
    raster = FloorRaster(FLOOR)
    # a partition across the room at x in [1.9, 2.1], leaving a gap at the top of width g
    for gap, pieces in ((0.3, 2), (0.6, 1)):
        walk = raster.walkable(raster.blocked([_box(1.9, 0.0, 2.1, 2.0 - gap)]))
        assert len(walk.sizes) == pieces, gap
    cut = raster.walkable(raster.blocked([_box(1.9, 0.0, 2.1, 1.7)]))
    assert cut.share == pytest.approx(0.5, abs=0.01)  # two equal halves
    assert set(np.unique(cut.labels[cut.free])) == {1, 2}
    at = lambda x, y: int(cut.labels[int(x / raster.cell), int(y / raster.cell)])  # noqa: E731
    assert at(0.5, 1.0) == at(1.5, 0.5) != at(2.5, 1.0) == at(3.5, 1.5)


def test_a_mask_only_marks_cells_inside_its_polygon() -> None:
    raster = FloorRaster(FLOOR, cell=0.1)
    m = raster.mask(_box(1.0, 0.5, 1.5, 1.0))
    assert m.sum() == 5 * 5
    assert not raster.mask(_box(10.0, 10.0, 11.0, 11.0)).any()
    with pytest.raises(ValueError, match="no extent"):
        FloorRaster(np.zeros((4, 2)))


@pytest.mark.parametrize("radius_cells", [1, 3, 4, 5, 7, 10, 13])
def test_the_free_floor_is_the_disk_erosion_whatever_the_radius(radius_cells: int) -> None:
    """Large robots are eroded through the distance transform, small ones by the disk: the cells
    kept are those of eroding by the disk, border included, on cluttered floors of any shape."""
    from scipy import ndimage

    rng = np.random.default_rng(radius_cells)
    l_shape = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 1.2], [1.5, 1.2], [1.5, 3.0], [0.0, 3.0]])
    for floor in (FLOOR, l_shape):
        raster = FloorRaster(floor)
        radius = radius_cells * raster.cell
        for _ in range(3):
            blocked = rng.random(raster.shape) < 0.004
            got = raster.walkable(blocked, radius).free
            yy, xx = np.mgrid[-radius_cells : radius_cells + 1, -radius_cells : radius_cells + 1]
            disk = xx**2 + yy**2 <= radius_cells**2
            want = ndimage.binary_erosion(raster.inside & ~blocked, structure=disk, border_value=0)
            assert got.any() and np.array_equal(got, want)
