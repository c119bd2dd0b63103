"""Wave 3, room data15: the algebraic default's honest intervals (issue 15) and the model-file
cases the TOML fuzz found (issue 16)."""

from __future__ import annotations

import numpy as np
import pytest

from physid.errors import ModelFileError
from physid.estimators import make
from physid.models.library import model_from_spec
from physid.models.spec import check_nominal_values, parse_model_text, symbolic_chain
from physid.simulate.msd import msd_paper_scenario

_CHAIN = """name = "arm"
kind = "chain"
[parameters]
m1 = {{ value = 1.0 }}
l1 = {{ value = 1.0 }}
[[joints]]
{geometry}
mass = "m1"
rotor_inertia = "{inertia}"
"""


def test_a_transform_entry_near_the_float_limit_is_refused_not_an_overflow_warning():
    # fuzz: R Rᵀ overflowed (RuntimeWarning) for an entry of 1e308
    text = _CHAIN.format(
        geometry='transform = [["1e308", 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]',
        inertia="0",
    )
    spec = parse_model_text(text)
    check_nominal_values(spec)
    with pytest.raises(ModelFileError, match=r"not orthonormal .*max \|R Rᵀ − I\| = inf"):
        symbolic_chain(spec)


def test_abs_of_exp_derives_as_a_real_expression():
    # fuzz: sympy writes abs(exp(m1)) as exp(re(m1)); the derivation's printers refused `re`
    text = _CHAIN.format(geometry='dh = { a = "l1", alpha = "m1" }', inertia="abs(exp(m1))")
    model = model_from_spec(parse_model_text(text), cache=False)
    # one joint: M = m1 l1² + rotor inertia = 1 + e at the nominal values, any q
    assert model.mass_matrix(np.array([[0.3]]))[0, 0, 0] == pytest.approx(1.0 + np.e, rel=1e-12)
