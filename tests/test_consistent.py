"""Log-Cholesky parametrisation of the pseudo-inertia (physid.estimators.consistent)."""

from __future__ import annotations

import numpy as np
import pytest

from physid.estimators.consistent import log_cholesky_to_standard, standard_to_log_cholesky
from physid.models.inertial import pseudo_inertia, standard_from_physical


def test_round_trip_of_a_real_body():
    p10 = standard_from_physical(2.5, [0.1, -0.05, 0.2], [0.03, 0.001, -0.002, 0.04, 0.0005, 0.05])
    x = standard_to_log_cholesky(p10)
    np.testing.assert_allclose(log_cholesky_to_standard(x), p10, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("seed", range(5))
def test_any_ten_numbers_give_a_realisable_body(seed):
    x = np.random.default_rng(seed).normal(scale=2.0, size=10)
    p10 = log_cholesky_to_standard(x)
    assert p10[0] > 0
    assert np.linalg.eigvalsh(pseudo_inertia(p10))[0] > 0


def test_an_impossible_body_is_lifted_to_the_boundary():
    bad = np.array([1.0, 0, 0, 0, 0.1, 0, 0, 0.1, 0, 0.5])  # ZZ > XX + YY: triangle violated
    back = log_cholesky_to_standard(standard_to_log_cholesky(bad))
    eig = np.linalg.eigvalsh(pseudo_inertia(back))
    assert eig[0] > 0
    assert eig[0] < 1e-6 * eig[-1] + 1e-9
