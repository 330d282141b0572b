"""The pull test itself (``physics.pull_parts``) on small hand-written MJCF worlds: the part is
pulled by a hand, not by a drive that shoves its own carcass back, and what a drawer carries rides
with it however it is stacked."""

from __future__ import annotations

from scenemosaic.physics import pull_parts

_WORLD = """
<mujoco>
  <option timestep="0.002" integrator="implicitfast" cone="elliptic" impratio="10"/>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1" friction="{floor_friction} 0.005 0.0001"/>
    <body name="chest" pos="0 0 0.4">
      <freejoint name="chest_free"/>
      <geom name="chest_shell" type="box" size="0.3 0.25 0.4" pos="0 0 0" mass="8" contype="0" conaffinity="0"/>
      <geom name="chest_foot" type="box" size="0.3 0.25 0.01" pos="0 0 -0.39" mass="1" friction="{floor_friction} 0.005 0.0001"/>
      <geom name="chest_top" type="box" size="0.3 0.25 0.01" pos="0 0 0.39" mass="1"/>
      <body name="chest/drawer_0" pos="0 0 0">
        <joint name="chest/drawer_0" type="slide" axis="1 0 0" range="0 0.4" damping="1"/>
        <geom name="drawer_floor" type="box" size="0.28 0.23 0.005" mass="20"/>
      </body>
    </body>
    <body name="vase" pos="0 0 0.8995">
      <freejoint name="vase_free"/>
      <geom name="vase_geom" type="cylinder" size="0.06 0.1" mass="1" friction="1 0.005 0.0001"/>
    </body>
    {load}
  </worldbody>
</mujoco>
"""

_LOAD = """
    <body name="box" pos="0 0 0.4549">
      <freejoint name="box_free"/>
      <geom name="box_geom" type="box" size="0.08 0.08 0.05" mass="0.5" friction="1 0.005 0.0001"/>
    </body>
    <body name="bowl" pos="0 0 0.5298">
      <freejoint name="bowl_free"/>
      <geom name="bowl_geom" type="box" size="0.05 0.05 0.025" mass="0.2" friction="1 0.005 0.0001"/>
    </body>
"""


def _chest(floor_friction: float, load: str = "") -> str:
    return _WORLD.replace("{floor_friction}", str(floor_friction)).replace("{load}", load)


def test_pulling_a_drawer_does_not_shove_its_chest_across_a_slippery_floor(tmp_path) -> None:
    # a laden drawer of 20 kg started towards its pace: a drive between drawer and chest pushes the
    # 11 kg chest back as hard as it pulls the drawer, more than the slippery floor holds, and the
    # chest slides away from the hand that pulls, the vase on its top with it (counted as pushed,
    # 9 cm); pulled by a hand, the chest stays where it stands
    path = tmp_path / "chest.xml"
    path.write_text(_chest(0.1))
    (pull,) = pull_parts(path)
    assert pull.joint == "chest/drawer_0"
    assert pull.passed, pull
    assert pull.reached >= 0.8 * 0.4


def test_what_a_drawer_carries_rides_with_it_however_it_is_stacked(tmp_path) -> None:
    # a box in the drawer and a bowl on the box: both ride out with the drawer, neither is pushed
    path = tmp_path / "chest.xml"
    path.write_text(_chest(1.0, _LOAD))
    (pull,) = pull_parts(path)
    assert pull.passed, pull
    assert pull.pushed_m < 0.02
