"""benchmarks/model_vs_thesis.py counts the geom pairs that reach the narrowphase, by body pair, and how close two
bodies' hulls come over random hand poses.

Seeded faults: the contype/conaffinity test left out of the counting filter -> the pair that the bitmasks exclude is
counted and the first test fails; the distance's sign dropped (abs) -> the overlapping pair reads as apart and the
second test fails.
"""

from __future__ import annotations

import mujoco

from tests.benchmarks.scripts import load

# Three boxes side by side: a and b overlap, c overlaps b but its bitmasks meet nothing (and a is 3 cm from c); the
# hand joint moves b.
SCENE = """
<mujoco>
  <worldbody>
    <body name="a"><geom type="box" size="0.1 0.1 0.1"/></body>
    <body name="b" pos="0.15 0 0">
      <joint name="right_hand_slide" type="slide" axis="1 0 0" range="-0.05 0.2"/>
      <geom type="box" size="0.1 0.1 0.1"/>
    </body>
    <body name="c" pos="0.23 0 0">
      <geom type="box" size="0.1 0.1 0.1" contype="2" conaffinity="2"/>
      <geom type="sphere" size="0.01" pos="0.5 0 0"/>  <!-- so MuJoCo's body-level filter lets b and c through -->
    </body>
  </worldbody>
  <option gravity="0 0 0"/>
</mujoco>
"""


def test_narrowphase_pairs_counts_what_the_bitmasks_let_through() -> None:
    bench = load("model_vs_thesis")
    model = mujoco.MjModel.from_xml_string(SCENE)
    pairs = bench.narrowphase_pairs(model, mujoco.MjData(model), steps=10)
    assert pairs == {("a", "b"): 1.0}
    assert mujoco.get_mjcb_contactfilter() is None  # MuJoCo's own filter is back


def test_closest_approach_is_negative_where_hulls_overlap() -> None:
    bench = load("model_vs_thesis")
    model = mujoco.MjModel.from_xml_string(SCENE)
    overlap, apart = bench.closest_approach(model, [("a", "b"), ("a", "c")], samples=50)
    # b slides from 0.1 to 0.35 m: its box overlaps a's by up to 0.1 m; c stays 0.03 m from a.
    assert overlap < -0.05
    assert abs(apart - 0.03) < 1e-6
