"""The base parameters of a URDF whose angles are rounded in the file (1.5708 for π/2).

Kinds of test (docs STYLE.md): equivalence (the rounded robot has the exact robot's base set,
and its kept columns reproduce the whole regressor to the rounding), and the counter-case (a
genuinely different angle keeps its own base parameter; the strict rank counts the rounding).
"""

from __future__ import annotations

import numpy as np
import pytest

import physid
from physid.models.base import RANK_RTOL

URDF = """<?xml version="1.0"?>
<robot name="r3">
  <link name="base"/>
  <link name="l1"><inertial><origin xyz="0 0.02 0.1"/><mass value="2"/>
    <inertia ixx="0.02" iyy="0.02" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="l2"><inertial><origin xyz="0.2 0 0.01"/><mass value="1.5"/>
    <inertia ixx="0.01" iyy="0.03" izz="0.03" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="l3"><inertial><origin xyz="0.1 0.01 0"/><mass value="1"/>
    <inertia ixx="0.005" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="100" velocity="3"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0 0 0.1" rpy="ANGLE 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="100" velocity="3"/></joint>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/>
    <origin xyz="0.4 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="100" velocity="3"/></joint>
</robot>
"""


def _model(folder, angle: str):
    """The 3-joint arm with joint 2's origin rolled by ``angle`` (as written in the file), and
    a rotor inertia and viscous friction per joint."""
    urdf = folder / f"arm_{angle}.urdf"
    urdf.write_text(URDF.replace("ANGLE", angle), encoding="utf-8")
    side = folder / f"arm_{angle}.toml"
    joints = "".join(f"[joints.j{k}]\narmature = 0.0\nviscous = 0.0\n" for k in (1, 2, 3))
    side.write_text(f'name = "arm"\nextends = "{urdf.as_posix()}"\n{joints}', encoding="utf-8")
    return physid.load_model(side)


def test_an_angle_rounded_in_the_file_has_the_exact_robots_base_parameters(tmp_path, monkeypatch):
    monkeypatch.setenv("PHYSID_CACHE_DIR", str(tmp_path / "cache"))
    exact = _model(tmp_path, repr(np.pi / 2)).base_parameters()
    model = _model(tmp_path, "1.5708")  # 3.7e-6 rad off
    rounded = model.base_parameters()
    assert rounded.n_base == exact.n_base == 19
    assert rounded.independent == exact.independent
    # the same names: Ia2 joins ZZ2 alone, not (at the level of its residual) every column
    assert rounded.base_names == exact.base_names
    zz2 = rounded.base_names.index("ZZ2R")
    assert {
        n for n, c in zip(model.regressor_names, rounded.base_matrix[zz2], strict=True) if c
    } == {
        "ZZ2",
        "Ia2",
        "m3",
    }
    # the disk cache takes the regrouped set back in another process
    again = _model(tmp_path, "1.5708")
    assert again.base_parameters().base_names == exact.base_names and again.base_from_cache
    # the regrouping holds to the rounding: ‖Y − Y_kept K‖ about 1e-6 of the largest column
    rng = np.random.default_rng(4)
    q, qd, qdd = rng.uniform(-2, 2, (50, 3)), rng.normal(size=(50, 3)), rng.normal(size=(50, 3))
    Y = np.asarray(model.regressor(q, qd, qdd)).reshape(-1, len(model.regressor_names))
    K, ind = np.asarray(rounded.base_matrix), np.asarray(rounded.independent_index)
    err = np.linalg.norm(Y - Y[:, ind] @ K, axis=0).max() / np.linalg.norm(Y, axis=0).max()
    assert 1e-9 < err < 0.1 * RANK_RTOL


@pytest.mark.parametrize(("angle", "n_base"), [("1.5708", 20), ("1.5698", 20), ("1.5", 20)])
def test_the_strict_rank_counts_the_rounding_and_a_real_angle_keeps_its_parameter(
    tmp_path, angle, n_base
):
    model = _model(tmp_path, angle)
    assert model.base_parameters(rtol=1e-9).n_base == n_base
    if angle != "1.5708":  # 1e-3 and 0.07 rad off a right angle: Ia2 stays its own parameter
        assert model.base_parameters().n_base == n_base
