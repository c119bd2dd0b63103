"""physid.models.inertial: physical ↔ standard ↔ pseudo-inertia, and pinocchio's order."""

import numpy as np
import pytest

from physid.errors import InputError
from physid.models import inertial


def _random_body(rng):
    A = rng.normal(size=(3, 3))
    Q, _ = np.linalg.qr(A)
    moments = rng.uniform(0.2, 1.0, 3)
    moments[2] = min(moments[2], moments[0] + moments[1])
    ic = Q @ np.diag(moments) @ Q.T
    return rng.uniform(0.5, 5.0), rng.normal(size=3) * 0.3, inertial.inertia_vector(ic)


def test_standard_physical_round_trip():
    rng = np.random.default_rng(0)
    for _ in range(20):
        m, c, ic = _random_body(rng)
        p = inertial.standard_from_physical(m, c, ic)
        m2, c2, ic2 = inertial.physical_from_standard(p)
        assert m2 == pytest.approx(m)
        np.testing.assert_allclose(c2, c, atol=1e-13)
        np.testing.assert_allclose(ic2, ic, atol=1e-13)


def test_parallel_axis_point_mass():
    p = inertial.standard_from_physical(2.0, [0.0, 0.0, 0.5], np.zeros(6))
    # a point mass at z = 0.5: XX = YY = m z², ZZ = 0, first moment m z
    np.testing.assert_allclose(p, [2, 0, 0, 1.0, 0.5, 0, 0, 0.5, 0, 0], atol=1e-15)


def test_pseudo_inertia_round_trip_and_definiteness():
    rng = np.random.default_rng(1)
    m, c, ic = _random_body(rng)
    p = inertial.standard_from_physical(m, c, ic)
    J = inertial.pseudo_inertia(p)
    assert np.all(np.linalg.eigvalsh(J) > 0)
    np.testing.assert_allclose(inertial.pseudo_inertia_to_standard(J), p, atol=1e-14)
    assert inertial.check_physical(p) == []
    bad = p.copy()
    bad[9] = -1.0  # ZZ negative: impossible
    assert inertial.check_physical(bad)
    assert np.linalg.eigvalsh(inertial.pseudo_inertia(bad))[0] < 0


def test_triangle_inequality_reported():
    p = inertial.standard_from_physical(1.0, [0, 0, 0], [0.1, 0, 0, 0.1, 0, 0.5])
    (msg,) = inertial.check_physical(p)
    assert "triangle" in msg
    assert "not positive" in inertial.check_physical(np.r_[-1.0, np.zeros(9)])[0]


def test_pinocchio_order_both_ways():
    p = np.arange(10.0)
    pin = inertial.to_pinocchio_order(p)
    # physid XX XY XZ YY YZ ZZ = 4..9 → pinocchio Ixx Ixy Iyy Ixz Iyz Izz
    assert pin.tolist() == [0, 1, 2, 3, 4, 5, 7, 6, 8, 9]
    np.testing.assert_array_equal(inertial.from_pinocchio_order(pin), p)


def test_pinocchio_order_matches_pinocchio():
    import pinocchio as pin

    rng = np.random.default_rng(3)
    m, c, ic = _random_body(rng)
    p = inertial.standard_from_physical(m, c, ic)
    I = pin.Inertia(m, c, inertial.inertia_matrix(ic))
    np.testing.assert_allclose(inertial.to_pinocchio_order(p), I.toDynamicParameters(), atol=1e-13)


def test_transform_standard_matches_rotation_and_shift():
    rng = np.random.default_rng(4)
    m, c, ic = _random_body(rng)
    p = inertial.standard_from_physical(m, c, ic)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    if np.linalg.det(Q) < 0:
        Q[:, 0] *= -1
    t = rng.normal(size=3)
    out = inertial.transform_standard(p, Q, t)
    expect = inertial.standard_from_physical(
        m, Q @ c + t, inertial.inertia_vector(Q @ inertial.inertia_matrix(ic) @ Q.T)
    )
    np.testing.assert_allclose(out, expect, atol=1e-13)


def test_errors():
    with pytest.raises(InputError, match="m > 0"):
        inertial.physical_from_standard(np.zeros(10))
    with pytest.raises(ValueError, match="10 entries"):
        inertial.pseudo_inertia(np.zeros(9))
